"""``kontur serve --port DEVICE``: the served moves made by a board, over ``kontur send``'s
protocol.

:class:`PortMotion` is the session's :class:`~kontur.grbl.motion.Motion` (the virtual clock
still paces the planner: which lines are taken, when ``ok`` comes) whose segments are also
framed and sent to the board by :class:`kontur.send.Feeder` (the handshake, flow control and
checks of ``kontur send``). The frames of a run of motion are those of :func:`kontur.planner.
frames` (``CONFIG``, a ``FEED`` and a move for each segment, a tool change's ``TOOL`` frame
between them, ``STOP``; LINE3 and HELIX on a 3-axis board), planned with the
same look-ahead as ``kontur run``: a segment is sent once the known path after it is long
enough to stop in (:func:`reach`: no later line can change its plan), planned together with
the run's segments sent within that distance before it; the run ends (the rest and ``STOP``)
once no line has come for :data:`SETTLE` s and the session has none waiting, or sooner, once
the board has less than :data:`LOW` s of motion left (:meth:`PortMotion.left`): a sender
slower than the machine makes it slow down and stop at the last line taken (as Grbl's
starved planner does), never run dry at speed. A program that
streams without a pause is thus sent as ``kontur send`` sends it, frame for frame (unless the
planner fills with segments shorter together than that distance: they are sent then, planned
to stop at the last, as Grbl's full planner slows the machine). The board's backlog counts in
the planner's blocks (:attr:`PortMotion.planned`): a sender is held back by a board behind.

What a status report says is the board's: its position (``STATUS``, asked for every
:data:`POLL` s, and once more after the last frame's answer), and ``Run`` while it has frames
unanswered or says it moves. A board in ALARM (its e-stop, a limit) is Grbl's ``ALARM:10``
(e-stop, as grblHAL numbers it) or ``ALARM:1`` (hard limit); a board that fails the protocol
(:class:`kontur.send.SendError`) is ``ALARM:3`` with the reason in a ``[MSG:...]``. A soft
reset sends ``ABORT`` and takes the position where the board stopped. Feed hold, resume and
the feed, rapid and spindle overrides are the board's ``HOLD``, ``RESUME`` and ``OVERRIDE`` frames
(:meth:`kontur.send._Sender.command`), sent at once beside the virtual machine's own (which
paces the planner); while held no frame is overdue.
"""

import time
import types

from kontur import registry
from kontur.grbl.motion import Motion
from kontur.grbl.protocol import PLANNER_BLOCKS
from kontur.hdl.motion.protocol import INPUT_NAMES
from kontur.planner import frames as program_frames, plan, step_length
from kontur.send import ABORT_WAIT, SendError, Feeder, _frame_plan

__all__ = ["PortMotion", "reach", "SETTLE", "LOW", "POLL"]

#: Seconds with no new line (and none waiting) before the run's last segments and its STOP
#: are sent.
SETTLE = 0.25
#: Seconds of planned motion the board has left at which the run ends (the segments held back
#: for their look-ahead sent, planned to stop at the last, and STOP): a sender slower than the
#: machine makes it slow down and stop, never run dry at speed.
LOW = 0.03
#: Seconds between two QUERYs while the board has frames.
POLL = 0.1

#: The board's STATE byte for ALARM, and its inputs' bits (:data:`kontur.hdl.motion.protocol.
#: INPUT_NAMES`): the e-stop's, the limits'.
ALARM_STATE, ESTOP, LIMITS = 4, 1, 6

#: The inputs' letters in a status report's ``Pn:`` field, in Grbl's order (the e-stop's is
#: grblHAL's).
PIN_LETTERS = (("limit_x", "X"), ("limit_y", "Y"), ("limit_z", "Z"), ("probe", "P"),
               ("feed_hold", "H"), ("cycle_start", "S"), ("estop", "E"))


def reach(machine):
    """How far (mm) a plan's look-ahead reaches: the distance to stop from twice the machine's
    maximum feed (:attr:`Motion._fastest`, above any planned speed) at its acceleration. A
    segment followed by this much known path has its final plan (no later line can lower its
    exit: the machine could stop in time whatever comes), and a segment this far past the
    start of a batch's window is planned as if the run before the window were known."""
    fastest = machine.max_feed / 60 * 2
    return fastest ** 2 / (2 * machine.accel)


def _length(segment, spm):
    return sum(map(step_length, segment.steps)) / spm


class PortMotion(Motion):
    """The virtual machine's motion, every segment also made by the board on ``port`` (an
    open pyserial port); ``say`` takes a line for the sender, ``alarm(code)`` puts the
    session in ALARM; ``out`` is where a board's queue run dry at speed is said
    (:meth:`kontur.send.Feeder.ran_dry`)."""

    def __init__(self, machine, board, port, *, speed=1.0, timeout=10.0, clock=time.monotonic,
                 out=None):
        self.feeder = Feeder(machine, port, timeout=timeout, out=out)
        self.feeder.handshake()
        super().__init__(machine, board, speed=speed, position=self._board_position(),
                         clock=clock)
        self.say = self.alarm = lambda *args: None
        self.more = lambda: False           # the session has lines it will take
        self.pending = []                   # (segment, length mm) not yet sent
        self.context = []                   # the run's last ones sent, within reach
        self.running = False                # CONFIG sent, STOP not yet
        self.added = clock()
        self.asked = 0.0
        self.failed = None                  # the SendError that stopped the board
        self.alarmed = False
        self.unlocked = -1                  # the STATUS count when UNLOCK was sent
        self.settled = None                 # the STATUS count to pass once all is answered
        self.mark = (0, clock())            # (frames answered, since when): the running frame's start

    def _board_position(self):
        """Where the board's last STATUS says it is (steps): ``(x, y)``, with Z on a 3-axis
        board."""
        feeder = self.feeder
        return tuple(feeder.status[:2]) + (() if feeder.z is None else (feeder.z,))

    @property
    def can_home(self):
        """The board's controller has the homing engine (:attr:`kontur.registry.Board.
        homing`)."""
        return registry.board(self.board).homing

    def home(self):
        """``$H``: the homing cycle's frames (:func:`kontur.homing.homing_job`) to the board,
        after an UNLOCK if it is in ALARM (Grbl homes from the alarm lock); at its end the
        virtual machine is where the cycle left the board, and a pass without its switch
        stops the board (``ABORT``) and is ``ALARM:9``. Raises
        :exc:`kontur.machine.MachineError` for a machine file homing cannot use."""
        from kontur.homing import homing_job
        # (a 3-axis board's cycle: Z is not homed)
        job = homing_job(self.machine, tuple(self.position))
        if self.failed is not None:
            return
        status = self.feeder.status
        if status is not None and status[4] == ALARM_STATE:
            self.unlock()
        try:
            self.feeder.home(job)
        except SendError as error:
            self._fail(error)
        self.settled = -1

    def _homed(self):
        """The homing cycle's end, or its failure (a pass without its switch)."""
        feeder = self.feeder
        if feeder.homing_failed is not None:
            reason, feeder.homing, feeder.homing_failed = feeder.homing_failed, None, None
            self._stop_board()
            self.say(f"[MSG:{reason}]")
            self.alarm(9)
        elif not feeder.in_flight:
            self.position = tuple(feeder.homing.end[:len(self.position)])
            feeder.homing = None

    @property
    def reported(self):
        """Where the board says it is (steps)."""
        status = self.feeder.status
        return self._board_position() if status is not None and self.failed is None \
            else self.position

    @property
    def pins(self):
        """The board's inputs active now (its last STATUS's, filtered), as ``Pn:`` letters
        in Grbl's order: X, Y, Z (limits), P (probe), H (feed hold), S (cycle start), and E
        for the e-stop (grblHAL's letter, as its ``ALARM:10``)."""
        status = self.feeder.status
        if status is None or self.failed is not None:
            return ""
        inputs = status[6]
        return "".join(letter for name, letter in PIN_LETTERS
                       if inputs >> INPUT_NAMES.index(name) & 1)

    @property
    def busy(self):
        if self.failed is not None:
            return super().busy
        feeder = self.feeder
        return super().busy or bool(self.pending) or feeder.in_flight > 0 or \
            (self.settled is not None and feeder.reports <= self.settled) or \
            bool(feeder.status is not None and feeder.status[3] & 1)

    @property
    def planned(self):
        """The blocks in the planner: the virtual machine's, or the segments the board has
        still to make when it is behind (a sender is held back by the board then, as Grbl's
        planner holds it back)."""
        return max(super().planned, len(self.pending) + self.feeder.in_flight // 2)

    def add(self, block):
        if self.failed is not None or not block.segments:
            return
        super().add(block)
        spm = self.machine.steps_per_mm
        self.pending += [(segment, _length(segment, spm)) for segment in block.segments]
        self.added = self.clock()

    def tick(self):
        super().tick()
        if self.failed is not None:
            return
        try:
            self._drive()
        except SendError as error:
            self._fail(error)

    def left(self):
        """The planned motion (s) the board has still to make of the frames it was given: the
        frames not yet answered, less the time since the last answer (the running one's, at
        most), shortened by a feed override above 100 %."""
        feeder = self.feeder
        if feeder.answered != self.mark[0] or not feeder.in_flight:
            self.mark = (feeder.answered, self.clock())
        rest = sum(feeder.durations[feeder.answered:]) - (self.clock() - self.mark[1])
        return rest * 100 / max(100, self.overrides[0])

    def _drive(self):
        now = self.clock()
        final, ahead = len(self.pending), 0.0        # the segments whose plan is final
        limit = reach(self.machine)
        while final and ahead < limit:
            final -= 1
            ahead += self.pending[final][1]
        if len(self.pending) + self.feeder.in_flight // 2 >= PLANNER_BLOCKS - 1:
            final = len(self.pending)       # the planner full: no more look-ahead will come
        if final:
            self._send(final, end=False)
        left = self.left()                  # (every turn: it marks the answers' times)
        # The run ends (the rest, planned to stop at the last, and STOP) when no line has come
        # for SETTLE s, or sooner when the board is about to run out of motion (LOW s left).
        if self.pending and not self.more() and (
                now - self.added >= SETTLE or self.running and left < LOW):
            self._send(len(self.pending), end=True)
        feeder = self.feeder
        feeder.pump()
        if feeder.homing is not None:
            self._homed()
        if now - self.asked >= POLL:        # at rest too: an e-stop is an alarm at once
            self.ask()
        if feeder.in_flight:
            self.settled = -1               # a STATUS after the last answer is awaited
        elif self.settled == -1:            # every frame answered: where did it end?
            self.settled = feeder.reports
            self.ask()
        elif self.settled is not None and feeder.reports > self.settled:
            self.settled = None
            if feeder.status[3] & 1:        # still moving: ask again
                self.settled = -1
        self._check_alarm()

    def ask(self):
        """A QUERY (its STATUS read at the next turns)."""
        if self.failed is None:
            try:
                self.feeder.query()
            except SendError as error:
                self._fail(error)
            self.asked = self.clock()

    def _send(self, count, *, end):
        """The frames of the first ``count`` pending segments (with ``end``, the run's STOP
        after them), planned with the run's segments before and the pending ones after."""
        window = [segment for segment, _ in self.context + self.pending]
        items = plan(window, self.machine)[len(self.context):]
        sent, self.pending = self.pending[:count], self.pending[count:]
        batch = [segment for segment, _ in sent]
        # A 3-axis board's segments are the session's on three axes (LINE3, HELIX frames); a
        # tool change's stop is its TOOL frame (planner.dwell_frames).
        frames, lines = program_frames(batch, items[:count], self.machine)
        times, exits = _frame_plan(types.SimpleNamespace(segments=batch, items=items[:count],
                                                         machine=self.machine,
                                                         seconds=0.0), len(frames))
        first = 0 if not self.running else 1
        last = len(frames) if end else len(frames) - 1
        self.feeder.extend(frames[first:last], lines[first:last], times[first:last],
                           exits[first:last])
        self.settled = -1                   # a STATUS after their answers is awaited
        self.running = not end
        self.context = [] if end else self.context + sent
        behind, limit = 0.0, reach(self.machine)
        for index in range(len(self.context) - 1, -1, -1):
            behind += self.context[index][1]
            if behind >= limit:             # what is before this one changes nothing here
                del self.context[:index]
                break

    def _check_alarm(self):
        status = self.feeder.status
        if status is None or status[4] != ALARM_STATE or self.alarmed or \
                self.feeder.reports <= self.unlocked:      # the STATUS before the UNLOCK's
            return
        self.alarmed = True
        tripped = status[5]
        self._stop_board()
        self.alarm(10 if tripped & ESTOP or not tripped & LIMITS else 1)

    def _fail(self, error):
        self.failed = error
        self.say(f"[MSG:the board: {error}]")
        self.alarm(3)
        super().cancel()

    def _stop_board(self):
        """ABORT, then wait (:data:`ABORT_WAIT` s at most) for the outcomes of the frames in
        flight and the STATUS of where the board stopped; the model is put there."""
        feeder = self.feeder
        try:
            feeder.reset()
            deadline = time.monotonic() + ABORT_WAIT
            while feeder.in_flight and time.monotonic() < deadline:
                feeder.pump()
            feeder.status = None
            feeder.query()
            while feeder.status is None and time.monotonic() < deadline:
                feeder.pump()
        except SendError as error:
            self._fail(error)
            return
        self.pending, self.context, self.running = [], [], False
        self.settled = None if feeder.status is not None and not feeder.in_flight else -1
        super().cancel()
        if feeder.status is not None:
            self.position = self._board_position()

    def cancel(self):
        """A soft reset or a jog cancel: the board ABORTs, the machine is where it stopped."""
        if self.failed is None:
            self._stop_board()
        else:
            super().cancel()

    def unlock(self):
        """``$X``: the alarm left, the board's by an UNLOCK (not while its e-stop is pressed:
        its STATUS in ALARM again is a new alarm). Sent too when the board's state is not
        known (no STATUS yet since the ABORT that stopped it: a slow board), never taken on
        trust as left."""
        self.alarmed = False
        status = self.feeder.status
        if self.failed is None and (status is None or status[4] == ALARM_STATE):
            try:
                self.feeder.query(unlock=True)
                self.unlocked = self.feeder.reports
            except SendError as error:
                self._fail(error)

    def close(self):
        """The server ends: a board with frames still to make is stopped (ABORT)."""
        if self.failed is None and (self.feeder.in_flight or self.pending):
            try:
                self.feeder.reset()
            except SendError:
                pass                        # the port is gone: nothing more to do

    # ---- the operator's controls: the virtual machine's timing and the board's frames ----

    def _operate(self, command):
        """Send the board one of :meth:`kontur.send._Sender.command`'s controls."""
        if self.failed is None:
            try:
                self.feeder.command(command)
            except SendError as error:
                self._fail(error)

    def hold(self):
        """Feed hold: the board's HOLD (it ramps down along the path and holds)."""
        held = self.held
        super().hold()
        if not held:
            self._operate("hold")

    def resume(self):
        """Cycle start: the board's RESUME."""
        held = self.held
        result = super().resume()
        if held:
            self._operate("resume")
        return result

    def override(self, index, percent):
        """The feed (0), rapid (1) and spindle (2) overrides as the board's OVERRIDE (all three
        as they stand: the spindle's scales S in its tool outputs' PWM). A board built without
        overrides (:attr:`kontur.registry.Board.overrides`) keeps 100 %: the sender is told
        so."""
        if not registry.board(self.board).overrides:
            self.say(f"[MSG:the {registry.board(self.board).name}'s controller is built "
                     f"without the feed, rapid and spindle overrides]")
            return
        super().override(index, percent)
        self._operate((("feed", "rapid", "spindle")[index], percent))
