"""A Grbl 1.1 session on kontur's virtual machine: bytes in, lines out.

:class:`Session` is the device a sender talks to, with no I/O of its own: :meth:`Session.
receive` takes the bytes a sender wrote (the real-time ones acted on at once, the others into
the 128-byte receive buffer), :meth:`Session.poll` takes the complete lines the planner has
room for, answers each ``ok`` or ``error:N`` and moves the machine's clock; every line it says
goes to ``send``. G-code lines go through kontur's reader (:class:`kontur.gcode.Stream`: one
interpreter whose modal state, work offsets and parameters carry from line to line, as
LinuxCNC reads a program) and the lattice of ``kontur run``
(:func:`kontur.planner.lattice`), so that a served program makes the steps a run one does.
On a 3-axis board (the ULX3S's) Z moves as in ``kontur run`` (LINE3 and HELIX frames); on a
board with tool outputs M3/M4/M5, S and M7/M8/M9 are tool changes (TOOL frames,
:class:`kontur.machining.ToolStates`' rules, laser mode's included), each a stop queued
between the moves as ``kontur run`` places it (:func:`kontur.machining.tool_stop`). A board without them refuses a
Z move, and a spindle or coolant switched on, with ``error:20`` and the reason.
"""

import copy
from dataclasses import replace
from fractions import Fraction

from kontur import registry
from kontur.gcode import Z_REFUSAL, GCodeError, Stream, parse, plane_arc
from kontur.grbl import protocol as p
from kontur.grbl.motion import Block, Motion
from kontur.grbl.settings import REFUSED, SettingError, Settings
from kontur.machining import ToolStates, check_travel, estimate_steps, tool_stop
from kontur.planner import ProgramError, lattice, plan
from kontur.sim.models.errors import InputError

__all__ = ["Session", "LineError"]


class LineError(Exception):
    """A line refused: Grbl's ``code`` and kontur's ``reason`` (sent as ``[MSG:...]``)."""

    def __init__(self, code, reason=None, *, soft_limit=False):
        super().__init__(reason or f"error {code}")
        self.code, self.reason = code, reason
        self.soft_limit = soft_limit


class Session:
    """Grbl on ``machine`` (a :class:`kontur.machine.Machine`, read from ``machine_file`` if
    given: its settings' writes are kept there) and ``board``; the virtual clock runs
    ``speed`` times real time; ``send`` takes each line said (no line end). ``motion``: the
    machine's motion when not the virtual one (:class:`kontur.grbl.board.PortMotion`)."""

    def __init__(self, machine, board, send, *, speed=1.0, clock=None, machine_file=None,
                 motion=None):
        self.board, self.send = board, send
        item = registry.board(board)
        self.axes, self.tools = item.axes, item.tools
        options = {} if clock is None else {"clock": clock}
        self.motion = motion or Motion(machine, board, speed=speed, **options)
        self.settings = Settings(machine, machine_file, homing=self.motion.can_home,
                                 board=board)
        self._homing = False                   # $H: the cycle runs (Grbl's Home state)
        self.rx = bytearray()
        self.alarm = self.check = False
        self.number = 0                        # lines received
        self.moves = []                        # every move served (for the summary)
        self.startup = ["", ""]                # $N0, $N1
        self.info = "kontur virtual machine"   # $I
        self._waiting = None                   # a reply held until the motion ends (M2/M30)
        self._pause = False                    # M0: a feed hold once the motion ends
        self._dwell = None                     # G4: (seconds, virtual end) once it ends
        self._critical = False                 # a soft limit: nothing taken until ctrl-X
        self._reset_after = False              # $C off, $RST=: a reset after the ok
        self._reports = 0
        self.z = None                          # the first Z a program gives (2-axis board)
        self.spindle, self.coolant = "M5", "M9"
        self.tools_set = ToolStates(machine)   # the tool state the queued changes leave
        self.reader = None
        self._reset_reader()
        self._welcome()

    @property
    def machine(self):
        return self.settings.machine

    def lines_ahead(self):
        """Complete lines are in the receive buffer, to be taken without waiting for the
        motion's end (a full planner takes them as it empties)."""
        return self._waiting is None and (b"\n" in self.rx or b"\r" in self.rx)

    def board_alarm(self, code):
        """The machine behind stopped itself (a board's e-stop, limit, or failure): Grbl's
        ``ALARM:code``, and the alarm lock until ``$X``."""
        self.rx.clear()
        self._waiting = None
        self.alarm = True
        self.motion.tool = None                # the board's halt turned its tool outputs off
        self.tools_set = ToolStates(self.machine)
        if self._homing:                       # a pass without its switch: where it stopped
            self._homing = False
            self._sync()
        self.send(f"ALARM:{code}")

    # ---- bytes in -----------------------------------------------------------------------

    def receive(self, data):
        """Bytes from the sender: real-time ones acted on now, in order; the rest buffered."""
        for byte in data:
            if byte in p.REALTIME:
                self._realtime(byte)
            else:
                self.rx.append(byte)

    def _realtime(self, byte):
        motion = self.motion
        if byte == p.STATUS:
            self.send(self.status())
        elif byte == p.RESET:
            self.reset()
        elif byte == p.HOLD:
            if motion.kind == "jog":
                motion.cancel()
                self._sync()
            elif not (self.alarm or self.check):
                motion.hold()
        elif byte == p.RESUME:
            if motion.held:
                motion.resume()
        elif byte == p.JOG_CANCEL:
            if motion.kind == "jog":
                motion.cancel()
                self._sync()
        elif byte in p.FEED_OVERRIDES or byte in p.SPINDLE_OVERRIDES:
            index, table = (0, p.FEED_OVERRIDES) if byte in p.FEED_OVERRIDES else \
                (2, p.SPINDLE_OVERRIDES)
            how, amount = table[byte]
            value = amount if how == "set" else motion.overrides[index] + amount
            motion.override(index, min(max(value, p.OVERRIDE_MIN), p.OVERRIDE_MAX))
        elif byte in p.RAPID_OVERRIDES:
            motion.override(1, p.RAPID_OVERRIDES[byte])
        # the other bytes of 0x80-0xFF (safety door, coolant toggles): nothing to act on

    # ---- the main loop's turn -----------------------------------------------------------

    def poll(self):
        """Move the clock, take every line the planner has room for, answer it; the moves
        taken are planned (together) and started."""
        self.motion.tick()
        self._take()
        self.motion.tick()

    def _take(self):
        if self._critical:                     # Grbl's critical event loop: stopped, then
            if self.motion.held and not self.motion.stopping:       # the queue dropped
                self.motion.cancel()
                self.motion.held = False
            return
        while True:
            if self._waiting is not None:
                if self.motion.busy:
                    return
                if self._dwell is not None:    # G4: the virtual clock waits it out
                    seconds, end = self._dwell
                    if end is None:
                        self._dwell = seconds, self.motion.now + seconds
                        return
                    if self.motion.now < end:
                        return
                    self._dwell = None
                if self._pause:                # M0: held at rest until ~, then the ok
                    self._pause = False
                    self.motion.hold()
                if self.motion.held:
                    return
                if self._homing:               # $H's ok: the reader where it left the machine
                    self._homing = False
                    self._sync()
                for line in self._waiting:
                    self.send(line)
                self._waiting = None
            ends = [i for i in (self.rx.find(b"\n"), self.rx.find(b"\r")) if i >= 0]
            if not ends or self.motion.planned >= p.PLANNER_BLOCKS - 1:
                return
            end = min(ends)
            raw = self.rx[:end].decode("latin-1")
            del self.rx[:end + 1]
            self.number += 1
            replies = self._answer(raw)
            if self._waiting is None:
                for line in replies:
                    self.send(line)
            else:
                self._waiting = replies
            if self._reset_after:
                self._reset_after = False
                self.reset()
            if self._critical:                 # a soft limit: nothing more until ctrl-X
                return

    def _answer(self, raw):
        """The lines that answer one received line: any messages, then ``ok`` or
        ``error:N``."""
        try:
            messages = self._line(raw) or []
            return [*messages, "ok"]
        except LineError as error:
            reason = [f"[MSG:line {self.number}: {error.reason}]"] if error.reason else []
            if error.soft_limit:               # Grbl: a hold, ALARM:2, no answer until reset
                self._critical = self.alarm = True
                self.motion.hold()
                return [*reason, "ALARM:2", "[MSG:Reset to continue]"]
            return [*reason, f"error:{error.code}"]

    def _line(self, raw):
        text = p.clean_line(raw)
        if len(text) >= p.LINE_BUFFER - 1:
            raise LineError(11)
        if not text and "(" not in raw:
            return None
        if text[:1] == "$":
            return self._system(text)
        if self.alarm or self.motion.kind == "jog":
            raise LineError(9)
        # The reader takes the line as sent (its comments: (MSG,...); its named parameters),
        # control characters dropped as Grbl drops them.
        return self._gcode("".join(ch for ch in raw if ch >= " " and ch != "\x7f"))

    # ---- state ---------------------------------------------------------------------------

    def state(self):
        """The machine state as a status report names it."""
        motion = self.motion
        if self.alarm:
            return "Alarm"
        if self._homing:
            return "Home"
        if self.check:
            return "Check"
        if motion.held:
            return "Hold:1" if motion.stopping else "Hold:0"
        if motion.busy:
            return "Jog" if motion.kind == "jog" else "Run"
        return "Idle"

    def status(self):
        """The real-time status report (``?``)."""
        motion = self.motion
        motion.tick()
        spm = self.machine.steps_per_mm
        mask = self.settings.value(10)
        offset = tuple(float(c) for c in self.reader.modes()["offset"])
        position = tuple(c / spm for c in motion.reported)
        if self.axes == 2:                     # Z where the program first put it
            position += (float(self.z) if self.z is not None else 0.0,)
        if not mask & 1:
            position = tuple(c - o for c, o in zip(position, offset))
        buffer = (max(p.PLANNER_BLOCKS - 1 - motion.planned, 0),
                  max(p.RX_BUFFER - len(self.rx), 0)) if mask & 2 else None
        offset = offset if self._reports % 10 == 0 else None
        self._reports += 1
        return p.status_report(self.state(), position, work=not mask & 1, buffer=buffer,
                               feed=motion.feed(), speed=self._speed(),
                               overrides=tuple(motion.overrides),
                               accessories=self._accessories(), pins=motion.pins,
                               inches=bool(self.settings.value(13)), offset=offset)

    def _speed(self):
        """The spindle speed reported (``FS:``): the machine's S (its last TOOL frame's) while
        its spindle is on, by the spindle override (the TOOL frame carries the programmed S;
        a board's OVERRIDE frame its spindle override: :mod:`kontur.grbl.board`)."""
        tool = self.motion.tool
        if tool is None or not tool["spindle"].value:
            return 0.0
        return float(tool["s"]) * self.motion.overrides[2] / 100

    def _accessories(self):
        """``A:``'s letters (interface.md): S (spindle clockwise, M3) or C (counter-clockwise,
        M4), F (flood, M8), M (mist, M7), from the machine's tool state (its last TOOL frame
        made)."""
        tool = self.motion.tool
        if tool is None:
            return ""
        return {1: "S", 2: "C"}.get(tool["spindle"].value, "") + \
            ("F" if tool["flood"] else "") + ("M" if tool["mist"] else "")

    def _reset_reader(self):
        """The reader afresh (Grbl's power-up modes: G0 G17 G21 G90 G94 G54, no G92 offset) at
        the machine's position; the work offsets G54-G59.3 and the G28/G30 positions are kept,
        as Grbl keeps them in its EEPROM."""
        old = self.reader
        self.reader = Stream(units="mm", parameters=self.machine.parameters)
        self.reader.state.motion = 0
        if old is not None:
            self.reader.state.g5x = old.state.g5x
            self.reader.state.home = old.state.home
            self.reader.state.pos[2] = old.state.pos[2]
            self.reader.state.z_given = old.state.z_given
        if self.axes == 3:                     # every move says where Z goes: where it is
            self.reader.state.z_given = True
        self.spindle, self.coolant = "M5", "M9"
        self.tools_set = ToolStates(self.machine)
        self._sync()

    def _sync(self):
        """The reader and the lattice where the machine is (after a stop, a setting)."""
        spm = Fraction(self.machine.steps_per_mm)
        self.reader.move_to(*(Fraction(c) / spm for c in self.motion.position))
        self.lattice_position = tuple(self.motion.position)

    def _welcome(self):
        self.send(p.WELCOME)
        if self.alarm:
            self.send("[MSG:'$H'|'$X' to unlock]")
            return
        for line in self.startup:
            if line:
                try:
                    self._gcode(line)
                    self.send(f">{line}:ok")
                except LineError as error:
                    self.send(f">{line}:error:{error.code}")

    def reset(self):
        """Soft reset (ctrl-X): motion stops, the queue and the receive buffer are emptied,
        the position kept; a reset while moving raises ``ALARM:3``, as Grbl's does."""
        motion = self.motion
        moving = motion.busy and (not motion.held or motion.stopping) and not self._critical
        self._critical = False
        motion.cancel()
        motion.held = False
        motion.overrides = [100, 100, 100]
        self.rx.clear()
        self._waiting = None
        self._pause = False
        self._dwell = None
        self.check = False
        self._reports = 0
        self._reset_reader()
        tool = motion.tool
        if tool is not None and (tool["spindle"].value or tool["mist"] or tool["flood"]):
            # Grbl's reset switches the spindle and coolant off; a board's ABORT leaves its
            # tool outputs as they are: a TOOL frame turns them off
            self.motion.add(Block("tool", self.number, [
                tool_stop(self.number, dict(self.tools_set.state), True,
                          self.lattice_position)]))
        if moving:
            self.send("ALARM:3")
            self.alarm = True
        self._welcome()

    # ---- G-code -------------------------------------------------------------------------

    def _read(self, text, reader):
        """The moves and events of one line read on ``reader`` (changed in place)."""
        blocks = parse(text)
        if not blocks:
            return [], []
        block = replace(blocks[0], line=self.number)
        if block.oword is not None:
            raise LineError(20, "O-words (subroutines, loops) are not served: Grbl has none; "
                                "kontur run reads them")
        moves, events = reader.feed([block])
        if reader.state.side is not None:
            raise LineError(20, "cutter compensation (G41/G42) is not served yet: kontur "
                                "run compensates a whole program")
        for move in moves:
            if move.plane != 17 and self.axes == 2:     # it moves Z, wherever it ends
                raise LineError(20, f"{Z_REFUSAL} ({plane_arc(move)})")
            if move.z is None or self.axes == 3:
                continue
            if self.z is None:
                self.z = move.z
            elif move.z != self.z:
                raise LineError(20, f"{Z_REFUSAL} (Z from {float(self.z):g} to "
                                    f"{float(move.z):g} mm)")
        return moves, events

    def _segments(self, move, kind=None):
        """The move on the lattice from where the last one ends, checked as ``kontur run``
        checks it: a move beyond the travel (``travel_x``/``travel_y``, on three axes
        ``travel_z``) is a soft limit (Grbl's ALARM:2; a jog's ``error:15``)."""
        item = registry.board(self.board)
        try:
            estimate_steps([move], self.machine)
            segments = lattice([move], self.machine, variants=(item.line[0], item.arc[0]),
                               widths=(item.line[1], item.arc[1]),
                               start=self.lattice_position, axes=item.axes)
            plan(segments, self.machine)            # a feed the generator cannot make
        except (ProgramError, InputError) as error:
            reason = getattr(error, "reason", str(error))
            raise LineError(p.error_code(reason), reason) from None
        try:
            check_travel(segments, self.machine, self.lattice_position)
        except ProgramError as error:
            raise LineError(15, error.reason, soft_limit=kind is None) from None
        return segments

    def _gcode(self, text, *, kind=None):
        """Read, check and queue one G-code line (``kind="jog"`` for a jog, on a copy of the
        modal state that is dropped after: only its end is kept)."""
        reader = copy.deepcopy(self.reader)
        z, position = self.z, self.lattice_position     # a line refused changes nothing
        try:
            moves, events = self._read(text, reader)
            planned = []
            for move in moves:
                planned.append((move, self._segments(move, kind)))
                if planned[-1][1]:                  # the next starts where this one ends
                    self.lattice_position = planned[-1][1][-1].end
        except GCodeError as error:
            self.z, self.lattice_position = z, position
            raise LineError(p.error_code(error.reason, 20), error.reason) from None
        except LineError:
            self.z, self.lattice_position = z, position
            raise
        changes = {}
        if kind is None:
            try:
                tools, changes = self._tool_changes(events, moves, reader.ended)
            except LineError:
                self.z, self.lattice_position = z, position
                raise
        messages = [f"[MSG:{event.text.strip()}]" for event in events
                    if event.kind == "message"]
        if kind is None:
            if not self.check:                     # check mode ($C) switches nothing
                self.tools_set = tools
            for event in events:
                if event.kind == "spindle":
                    self.spindle = event.text.split()[0]
                elif event.kind == "coolant":
                    code = event.text
                    self.coolant = "M9" if code == "M9" else " ".join(
                        sorted({*self.coolant.split(), code} - {"M9"}))
            ended = reader.ended
            if any(event.kind == "pause" and event.text == "M0" for event in events) \
                    and not self.check:            # M0 (Grbl ignores M1): a pause
                self._pause = True
            dwell = [move.seconds for move in moves if move.kind == "dwell"]
            if dwell and not self.check:           # G4: Grbl waits for the motion, then
                self._dwell = float(dwell[0]), None     # dwells, then says ok
            for code in (28, 30):                  # G28.1/G30.1: kept as Grbl keeps them
                if reader.state.home[code] != self.reader.state.home[code]:
                    self.settings.keep_home(code, reader.state.home[code])
            if ended:                              # M2/M30: Grbl's program end
                reader.program_end()
                self.spindle, self.coolant = "M5", "M9"
                messages.append("[MSG:Pgm End]")
            self.reader = reader
        else:
            ended = False
            if moves:
                self.reader.move_to(*moves[-1].end, moves[-1].z if self.axes == 3 else None)
        self.lattice_position = position
        for index, (move, segments) in enumerate([*planned, (None, [])]):
            if index in changes and not self.check:     # a tool change before the move
                line, state, stop = changes[index]
                self.motion.add(Block("tool", line, [tool_stop(line, state, stop,
                                                               self.lattice_position)]))
            if segments:
                self.lattice_position = segments[-1].end
            if self.check or not any(segment.steps for segment in segments):
                continue
            self.moves.append(move)
            self.motion.add(Block(kind or ("rapid" if move.kind == "rapid" else "feed"),
                                  move.line, segments))
        if ended or self._pause or self._dwell is not None:
            self._waiting = []                      # the ok waits for the motion's end
        return messages or None

    def _tool_changes(self, events, moves, ended):
        """The tool states after a line's ``events`` and ``moves`` and its changes: ``{moves
        before it: (line, state, stop)}``, as :func:`kontur.machining.tool_changes` places
        them in a whole program (:class:`kontur.machining.ToolStates` going on from the lines
        before; a change after the line's last move is made there, not held for the next
        line); at a program end (``ended``, M2/M30) everything on is switched off. A board
        without tool outputs refuses a change (``error:20``): M5, M9 and S, which leave them
        off, change nothing."""
        tools, changes = self.tools_set.copy(), {}
        for index in range(len(moves) + 1):
            taken = [event for event in events if event.move == index and tools.take(event)]
            change = tools.change(moves[index] if index < len(moves) else None,
                                  end=ended and index == len(moves))
            if change is None:
                continue
            if not self.tools:
                what = next((e.text.strip() for e in reversed(taken) if e.kind != "speed"),
                            taken[-1].text.strip())
                raise LineError(20, f"{what}: the "
                                    f"{registry.board(self.board).name}'s controller has no "
                                    f"tool outputs (spindle, coolant; the ulx3s's has them)")
            changes[index] = (taken[-1].line if taken else self.number, *change)
        return tools, changes

    def _jog(self, text):
        body = text[3:]
        try:
            blocks = parse(body)
        except GCodeError as error:
            raise LineError(p.error_code(error.reason, 20), error.reason) from None
        words = blocks[0].words if blocks else ()
        if any(w.letter not in "GXYZFN" or w.letter == "G" and w.code not in (20, 21, 53, 90, 91)
               for w in words):
            raise LineError(16)
        if not any(w.letter == "F" for w in words):
            raise LineError(22)
        if not any(w.letter in "XYZ" for w in words):
            raise LineError(26)
        words = " ".join(w.text for w in words)
        return self._gcode(f"G1 {words}", kind="jog")

    # ---- $ commands ---------------------------------------------------------------------

    def _system(self, text):
        motion = self.motion
        idle = not motion.busy and not motion.held and not self.check
        if text == "$":
            return [p.HELP]
        if text.startswith("$J"):
            if self.alarm or self.check or motion.held or motion.kind not in (None, "jog"):
                raise LineError(8)
            if not text.startswith("$J="):
                raise LineError(3)
            return self._jog(text)
        if text[1] in "$GCX":
            if len(text) != 2:
                raise LineError(3)
            return self._query(text[1])
        if not (idle or self.alarm):
            raise LineError(8)
        return self._idle_command(text)

    def _query(self, letter):
        motion = self.motion
        if letter == "$":
            if motion.busy or motion.held:
                raise LineError(8)
            return self.settings.lines()
        if letter == "G":
            return [self._modes()]
        if letter == "C":
            if self.check:
                self._reset_after = True
                return ["[MSG:Disabled]"]
            if self.alarm or motion.busy or motion.held:
                raise LineError(8)
            self.check = True
            return ["[MSG:Enabled]"]
        if self.alarm:                             # X
            self.alarm = False
            if hasattr(motion, "unlock"):          # a board's own alarm (--port)
                motion.unlock()
            return ["[MSG:Caution: Unlocked]"]
        return None

    def _modes(self):
        """``$G``: the parser state as Grbl reports it."""
        modes = self.reader.modes()
        inches = modes["inches"]
        motion = "G80" if modes["motion"] is None else f"G{modes['motion'] // 10}"
        system = modes["coordinate_system"]
        system = f"G{53 + system}" if system <= 6 else f"G59.{system - 6}"
        feed = float(modes["feed"] or 0)
        return (f"[GC:{motion} {system} G{modes['plane'] // 10} G{20 if inches else 21} "
                f"G{90 if modes['absolute'] else 91} G94 {self.spindle} {self.coolant} "
                f"T{modes['tool']} F{p.number(feed, 1 if inches else 0)} "
                f"S{p.number(float(modes['speed']), 0)}]")

    def _offsets(self):
        """``$#``: the work offsets, G28/G30, G92, the tool length and probe (mm)."""
        modes = self.reader.modes()

        def three(values):
            return ",".join(p.number(float(v)) for v in values)
        return [*(f"[G{53 + n}:{three(modes['systems'][n])}]" for n in range(1, 7)),
                f"[G28:{three(modes['home'][28])}]", f"[G30:{three(modes['home'][30])}]",
                f"[G92:{three(modes['g92'])}]", f"[TLO:{p.number(float(modes['tlo'][2]))}]",
                "[PRB:0.000,0.000,0.000:0]"]

    def _idle_command(self, text):
        if text == "$#":
            return self._offsets()
        if text.startswith("$H"):
            return self._home(text)
        if text == "$SLP":
            raise LineError(3, "sleep: kontur's virtual machine does not sleep")
        if text.startswith("$I"):
            if text == "$I":
                return [f"[VER:{p.VERSION}.20190830:{self.info}]",
                        f"[OPT:,{p.PLANNER_BLOCKS - 1},{p.RX_BUFFER}]"]
            if not text.startswith("$I="):
                raise LineError(3)
            self.info = text[3:]
            return None
        if text.startswith("$RST="):
            if text not in ("$RST=$", "$RST=#", "$RST=*"):
                raise LineError(3)
            if text != "$RST=#":
                self.settings.restore()
                self._machine_changed(self.settings.machine)
            self._reset_after = True
            return ["[MSG:Restoring defaults]"]
        if text.startswith("$N"):
            return self._startup(text)
        return self._setting(text)

    def _home(self, text):
        """``$H``: the homing cycle (kontur.homing's, Grbl's) on a board that has it, with
        ``$22=1``; ``ok`` once it has ended, the alarm lock left; a pass without its switch is
        ``ALARM:9``. Grbl's single-axis ``$HX`` is a compile-time option, not taken here."""
        if text != "$H":
            raise LineError(3, "homing: $H homes every axis of the machine file's homing_order")
        if not self.motion.can_home:
            raise LineError(5, REFUSED[22][1])
        if not self.settings.value(22):
            raise LineError(5, "homing is off: $22=1 turns it on")
        from kontur.machine import MachineError
        try:
            self.motion.home()
        except MachineError as error:
            raise LineError(5, f"homing: {error}") from None
        self.alarm = False
        self._homing = True
        self._waiting = []                     # the ok once the cycle has ended
        return None

    def _startup(self, text):
        if text == "$N":
            return [f"$N{n}={line}" for n, line in enumerate(self.startup)]
        head, _, line = text.partition("=")
        if not _ or head not in ("$N0", "$N1"):
            raise LineError(3)
        if self.alarm:
            raise LineError(8)
        if line:
            self._gcode(line)
        self.startup[int(head[2])] = line
        return None

    def _setting(self, text):
        parsed = p.parse_setting(text)
        if parsed is None:
            raise LineError(3 if "=" not in text else 2)
        try:
            machine = self.settings.write(*parsed)
        except SettingError as error:
            raise LineError(error.code, error.reason) from None
        if machine is not None:
            self._machine_changed(machine)
        return None

    def _machine_changed(self, machine):
        """A setting changed the machine (only while idle): the motion takes it, the reader
        is where the machine is on its lattice (its modes kept)."""
        self.motion.machine = machine
        self._sync()
