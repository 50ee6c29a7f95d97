// The host side of a machine-controller run, inside the Verilator simulation.
//
// kontur's MotionController (Verilog "top", ports clk, rx, tx, inputs, motion__step,
// motion__dir; its reset made inside, for its first 4 clocks: sim/fastrun.py's _FastTop)
// runs clock by clock; this testbench plays what a host does on the serial line:
// it sends the frames of a file onto rx, 8N1 at `divisor` clocks a bit, keeping at most
// `window` queued frames unanswered (the protocol's flow control; a QUERY waits for every
// frame before it to be answered), and parses the replies on tx. (Verilator names the port motion__step as motion___05Fstep.) It writes one line per event: "S clock step dir" at every rising edge of a step pin,
// "R clock type payload-hex" for every reply, and, built with -DKONTUR_TOOLS (a controller
// with tool outputs, port "tools"), "T clock word" at every change of the tool pins. Python
// sees the run only through these files.
//
// usage: fastrun [--schedule=FILE] FRAMES EVENTS DIVISOR WINDOW MAX_CLOCKS [VCD [VCD_CLOCKS]]
//   VCD_CLOCKS: dump only the first VCD_CLOCKS clocks (default: all)
//   FRAMES: for each frame a 16-bit little-endian length, then its bytes.
//   --schedule=FILE: the switch pins (port "inputs") and immediate frames at clocks after the
//     first step (kontur.sim.testbench.hostlink.write_schedule): a line "I word" (the pins
//     before any event), then "offset P word" (the pins from then), "offset U" (send an
//     UNLOCK) or "offset F hex" (send these bytes: a HOLD, RESUME, OVERRIDE, QUERY frame).
//     Each event applied is written "A clock P word", "A clock U" or "A clock F hex". With a schedule
//     the host sends no more queued frames once one is answered other than DONE, and
//     a QUERY waits for every event too (as HostLink does).

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <vector>

#include "Vtop.h"
#include "verilated.h"
#if VM_TRACE
#include "verilated_vcd_c.h"
#endif

static const uint8_t SYNC = 0xA5, OUTCOME = 0x80, ERROR = 0x82, QUERY = 0x20, ABORT = 0x21,
                     UNLOCK = 0x22;

struct Event { unsigned long long offset; char what; unsigned word; std::vector<uint8_t> bytes; };

static uint16_t crc16(const std::vector<uint8_t> &data) {
    uint16_t crc = 0xFFFF;
    for (uint8_t byte : data)
        for (int i = 7; i >= 0; i--) {
            bool top = ((crc >> 15) & 1) ^ ((byte >> i) & 1);
            crc = (uint16_t)(crc << 1);
            if (top) crc ^= 0x1021;
        }
    return crc;
}

static void append_bits(std::vector<uint8_t> &levels, const std::vector<uint8_t> &frame) {
    for (uint8_t byte : frame) {
        levels.push_back(0);
        for (int i = 0; i < 8; i++) levels.push_back((byte >> i) & 1);
        levels.push_back(1);
    }
}

int main(int argc, char **argv) {
    const char *schedule_path = nullptr;
    if (argc > 1 && std::strncmp(argv[1], "--schedule=", 11) == 0) {
        schedule_path = argv[1] + 11;
        argv[1] = argv[0];
        argv++;
        argc--;
    }
    if (argc < 6) {
        std::fprintf(stderr, "usage: fastrun [--schedule=FILE] FRAMES EVENTS DIVISOR WINDOW "
                             "MAX_CLOCKS [VCD [VCD_CLOCKS]]\n");
        return 2;
    }
    std::deque<Event> schedule;
    unsigned pins = 0;
    if (schedule_path) {
        FILE *file = std::fopen(schedule_path, "r");
        if (!file) { std::perror("fastrun"); return 1; }
        char line[1024];
        while (std::fgets(line, sizeof line, file)) {
            unsigned long long offset;
            char what;
            unsigned word = 0;
            char hex[1000] = "";
            if (line[0] == 'I') {
                if (std::sscanf(line + 1, "%u", &pins) != 1) return 1;
            } else if (std::sscanf(line, "%llu %c", &offset, &what) == 2) {
                Event event{offset, what, 0, {}};
                if (what == 'P') {
                    if (std::sscanf(line, "%llu %c %u", &offset, &what, &word) != 3) return 1;
                    event.word = word;
                } else if (what == 'F') {
                    if (std::sscanf(line, "%llu %c %999s", &offset, &what, hex) != 3) return 1;
                    for (size_t i = 0; hex[i] && hex[i + 1]; i += 2) {
                        unsigned byte;
                        if (std::sscanf(hex + i, "%2x", &byte) != 1) return 1;
                        event.bytes.push_back((uint8_t)byte);
                    }
                }
                schedule.push_back(event);
            }
        }
        std::fclose(file);
    }
    const bool scheduled = !schedule.empty();
    bool based = false;
    unsigned long long base = 0;
    FILE *in = std::fopen(argv[1], "rb");
    FILE *out = std::fopen(argv[2], "w");
    if (!in || !out) { std::perror("fastrun"); return 1; }
    const long divisor = std::atol(argv[3]);
    const long window = std::atol(argv[4]);
    const unsigned long long max_clocks = std::strtoull(argv[5], nullptr, 10);
    const unsigned long long vcd_clocks =
        argc > 7 ? std::strtoull(argv[7], nullptr, 10) : ~0ULL;

    std::deque<std::vector<uint8_t>> frames;
    for (;;) {
        uint8_t size[2];
        if (std::fread(size, 1, 2, in) != 2) break;
        std::vector<uint8_t> frame(size[0] | size[1] << 8);
        if (std::fread(frame.data(), 1, frame.size(), in) != frame.size()) return 1;
        frames.push_back(frame);
    }
    std::fclose(in);

    auto context = std::make_unique<VerilatedContext>();
    context->commandArgs(1, argv);
    auto top = std::make_unique<Vtop>(context.get());
#if VM_TRACE
    std::unique_ptr<VerilatedVcdC> vcd;
    if (argc > 6) {
        context->traceEverOn(true);
        vcd = std::make_unique<VerilatedVcdC>();
        top->trace(vcd.get(), 99);
        vcd->open(argv[6]);
    }
#endif

    // Host to machine: the bits of the frame being sent, one level every `divisor` clocks.
    std::vector<uint8_t> levels;
    size_t level_index = 0;
    long level_left = 0;
    long outstanding = 0;
    // Machine to host: the tx line's bytes and the reply frames they make.
    int rx_state = 0;                     // 0 idle, 1 receiving
    long rx_timer = 0;
    int rx_bit = 0;
    unsigned rx_byte = 0;
    std::vector<uint8_t> reply;
    unsigned long long answered = 0, queued_sent = 0;
    unsigned previous_step = 0;
#ifdef KONTUR_TOOLS
    unsigned previous_tools = 0;
#endif
    unsigned long long idle_after = 0;

    top->rx = 1;
    top->inputs = pins;
    top->clk = 0;
    top->eval();
    unsigned long long clock = 0;
    for (; clock < max_clocks; clock++) {
        bool reset = clock < 4;            // the top holds itself in reset (sim/fastrun.py)
        // ---- the schedule: machining time counts from the first step -------------------
        if (!based && !reset && answered == queued_sent && level_index == levels.size()
            && (frames.empty() || (frames.front().size() >= 2 && frames.front()[1] == QUERY))) {
            based = true;                  // no step, and the host waits to ask
            base = clock;
        }
        while (based && !schedule.empty() && clock >= base + schedule.front().offset) {
            Event event = schedule.front();
            schedule.pop_front();
            if (event.what == 'U' || event.what == 'F') {
                if (event.what == 'U') {
                    std::fprintf(out, "A %llu U\n", clock);
                } else {
                    std::fprintf(out, "A %llu F ", clock);
                    for (uint8_t byte : event.bytes) std::fprintf(out, "%02x", byte);
                    std::fprintf(out, "\n");
                }
                if (level_index == levels.size()) {
                    levels.clear();
                    level_index = 0;
                    level_left = divisor;
                }
                if (event.what == 'U') {
                    std::vector<uint8_t> body = {UNLOCK, 0};
                    uint16_t crc = crc16(body);
                    append_bits(levels, {SYNC, UNLOCK, 0, (uint8_t)(crc >> 8), (uint8_t)crc});
                } else {
                    append_bits(levels, event.bytes);
                }
            } else {
                std::fprintf(out, "A %llu P %u\n", clock, event.word);
                pins = event.word;
            }
        }
        top->inputs = pins;
        // ---- host to machine -----------------------------------------------------------
        if (!reset && level_index == levels.size() && !frames.empty()) {
            const std::vector<uint8_t> &frame = frames.front();
            bool queued = frame.size() < 2 || (frame[1] != QUERY && frame[1] != ABORT);
            // A QUERY waits for every frame before it to be answered (and every event); an
            // ABORT goes at once.
            bool may = queued ? outstanding < window
                              : (frame[1] == ABORT || (answered == queued_sent
                                                       && schedule.empty()));
            if (may) {
                levels.clear();
                level_index = 0;
                append_bits(levels, frame);
                outstanding += queued;
                queued_sent += queued;
                level_left = divisor;
                frames.pop_front();
            }
        }
        if (level_index < levels.size()) {
            top->rx = levels[level_index];
            if (--level_left == 0) { level_index++; level_left = divisor; }
        } else {
            top->rx = 1;
        }
        // ---- the clock edge ---------------------------------------------------------------
        top->clk = 1;
        top->eval();
#if VM_TRACE
        if (vcd && clock < vcd_clocks) vcd->dump((uint64_t)(2 * clock + 1));
#endif
        top->clk = 0;
        top->eval();
#if VM_TRACE
        if (vcd && clock < vcd_clocks) vcd->dump((uint64_t)(2 * clock + 2));
        if (vcd && clock + 1 == vcd_clocks) vcd->close();
#endif
        // ---- the pins, after the edge: the values of clock + 1 -----------------------------
        unsigned step = top->motion___05Fstep;
        unsigned rising = step & ~previous_step;
        if (rising) {
            std::fprintf(out, "S %llu %u %u\n", clock + 1, rising, (unsigned)top->motion___05Fdir);
            if (!based) { based = true; base = clock + 1; }
        }
        previous_step = step;
#ifdef KONTUR_TOOLS
        // The tool pins (port "tools", built with -DKONTUR_TOOLS): a line at each change.
        unsigned tools = top->tools;
        if (tools != previous_tools) std::fprintf(out, "T %llu %u\n", clock + 1, tools);
        previous_tools = tools;
#endif
        unsigned tx = top->tx;
        if (rx_state == 0) {
            if (!tx) { rx_state = 1; rx_timer = divisor + divisor / 2; rx_bit = 0; rx_byte = 0; }
        } else if (--rx_timer == 0) {
            rx_timer = divisor;
            if (rx_bit < 8) {
                rx_byte |= tx << rx_bit;
                rx_bit++;
            } else {
                rx_state = 0;
                reply.push_back((uint8_t)rx_byte);
                // A reply is SYNC type length payload crc-high crc-low.
                if (reply[0] != SYNC) reply.clear();
                else if (reply.size() >= 3 && reply.size() == (size_t)reply[2] + 5u) {
                    std::vector<uint8_t> body(reply.begin() + 1, reply.end() - 2);
                    uint16_t crc = (uint16_t)(reply[reply.size() - 2] << 8 | reply.back());
                    if (crc == crc16(body)) {
                        std::fprintf(out, "R %llu %02x", clock + 1, reply[1]);
                        for (size_t i = 3; i < reply.size() - 2; i++)
                            std::fprintf(out, " %02x", reply[i]);
                        std::fprintf(out, "\n");
                        if (reply[1] == OUTCOME || reply[1] == ERROR) {
                            outstanding--;
                            answered++;
                            // The machine stopped the stream: send no more of it.
                            if (scheduled && (reply[1] == ERROR || reply[4] != 0)) {
                                std::deque<std::vector<uint8_t>> queries;
                                for (auto &frame : frames)
                                    if (frame.size() >= 2 && frame[1] == QUERY)
                                        queries.push_back(frame);
                                frames.swap(queries);
                            }
                        }
                    }
                    reply.clear();
                }
            }
        }
        // Done: everything sent and answered, the line quiet for a while.
        if (frames.empty() && level_index == levels.size() && answered == queued_sent
            && rx_state == 0 && schedule.empty()) {
            if (idle_after == 0) idle_after = clock + 64 * divisor;
            if (clock >= idle_after) break;
        } else {
            idle_after = 0;
        }
    }
    std::fprintf(out, "E %llu\n", clock);
#if VM_TRACE
    if (vcd && clock < vcd_clocks) vcd->close();
#endif
    top->final();
    std::fclose(out);
    return clock >= max_clocks ? 3 : 0;
}
