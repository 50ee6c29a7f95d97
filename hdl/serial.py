"""The textbook's two-coordinate linear-circular interpolation node, bit-serial, and its cores.

The excerpt's figure ("Рис. 12", captioned "Рис. 10") names the node's elements: five
full-width shift registers Pr1-Pr5, two one-bit registers Pr6 and Pr7, two serial adders См1
and См2, AND and NOT gates Э1-Э7, a mode node, an output node and an end-of-frame node; in the
input mode the signal Ро loads x0, y0, xk, yk into the registers, and the current coordinates
in Pr1 and Pr2 are joined into one input of См1. It gives no wiring: :class:`SerialNode` is a
design of ours from exactly those elements (``docs/textbook.md``, with its timing diagram).
:class:`SerialLineCore` and :class:`SerialArcCore` are the node as a line core and as a
quadrant core.
"""

from amaranth import *
from amaranth.lib import enum, wiring
from amaranth.lib.wiring import In, Out

from .arc import ArcCoreSignature
from .elements import SerialAdder, ShiftRegister
from .elements._checks import check_width
from .engine import permit
from .line import LineCoreSignature

__all__ = ["SerialNode", "SerialLineCore", "SerialArcCore", "Phase", "word_length"]


def word_length(width):
    """Bits in the node's word, and clocks per step, for ``width``-bit coordinates."""
    return width + 2


class Phase(enum.Enum, shape=2):
    """The mode node's phase."""
    IDLE = 0            # ready for Ро
    INIT1 = 1           # a circle's first initialisation word: Q += x
    INIT2 = 2           # the last initialisation word: Q += ~y (circle) or ~xk (line)
    RUN = 3             # step words


class SerialNode(wiring.Component):
    """The two-coordinate linear-circular node: separate steps by the estimating function, one
    bit of every register per clock.

    Every register is a ring of ``W = width + 2`` bits (:func:`word_length`), least significant
    bit first, that turns once a word. Pr1 and Pr2 hold the current coordinates ``x`` and ``y``,
    Pr3 the estimating function ``Q``, Pr4 and Pr5 the end point ``xk``, ``yk``; Pr6 the axis of
    the next step (1: X), Pr7 one bit of delay that doubles an operand. ``Q = -D - 1`` for a line
    and ``-G - 1`` for a circle (D and G as in :class:`~kontur.hdl.textbook.SeparateLineCore` and
    :class:`~kontur.hdl.textbook.SeparateArcCore`: the text's F at the midpoint of the two candidate
    points), so that its sign bit alone is the decision, and the trajectory is theirs. Lines
    run from the origin to ``(xk, yk)``, both coordinates rising; circles in the native quadrant
    (X falls, Y rises) until X = 0.

    A frame is loaded in a clock in which :py:`po` (Ро) is high and :py:`ready`: Pr1 takes
    :py:`x0`, Pr2 :py:`y0`, Pr3 :py:`f0` (``yk`` for a line, ``residue = r2 - x0² - y0²`` for
    a circle), Pr4 :py:`xk`, Pr5 :py:`yk` (zero for a circle); :py:`circle` chooses the mode.
    Initialisation words follow, one for a line (``Q += ~xk``) and two for a circle (``Q += x0``,
    ``Q += ~y0``): ``W`` or ``2W`` clocks. :py:`start` marks their last clock; the steps come
    from the next. Each step word begins with a clock in which a step is due (:py:`due`): it
    waits there for :py:`tick`, makes the step along the axis of Pr6 in the clock of the
    permission and then runs freely through its other ``W - 1`` clocks, in which См1 forms the
    new coordinate (``± 1``), См2 the new Q (``± 2·operand``), Pr6 takes its sign and the
    end-of-frame node compares the coordinates with the end point (for a circle, X with 0).
    :py:`done` is high in the word's last clock when they match (a line of length zero ends so
    in the clock of :py:`start`), or in a clock in which :py:`stop` is high while it runs; a new
    frame may be loaded in that same clock. A load while the node is not ready is refused:
    :py:`error` pulses and the frame in progress goes on.

    .. wavedrom::

        { "signal": [
          { "name": "clk",   "wave": "p..................." },
          { "name": "po",    "wave": "010................." },
          { "name": "tick",  "wave": "1....0.1............" },
          { "name": "phase", "wave": "=.=...=...........=.",
            "data": ["Idle", "Init 2", "Run", "Idle"] },
          { "name": "bit",   "wave": "=.=====.============",
            "data": ["0", "0", "1", "2", "3", "0", "1", "2", "3", "0", "1", "2", "3", "0",
                     "1", "2", "3", "0"] },
          { "name": "start", "wave": "0....10............." },
          { "name": "due",   "wave": "0.....1.0..10..10..." },
          { "name": "step",  "wave": "0......=0..=0..=0...", "data": ["X", "Y", "X"] },
          { "name": "done",  "wave": "0.................10" },
          { "name": "ready", "wave": "1.0...............1." }
        ],
          "head": { "text": "line to (2, 1), W = 4: load, initialisation, a word a step" } }

    Parameters
    ----------
    width : :class:`int`
        Coordinate width: magnitudes up to ``2**width - 1``.

    Members
    -------
    po : :py:`In(1)`
        Ро, the input mode: load a frame.
    circle : :py:`In(1)`
        The frame is a circle's quadrant run (taken with :py:`po`).
    x0, y0 : :py:`In(width)`
        Start point (zero for a line).
    f0 : :py:`In(signed(width + 1))`
        Initial contents of Pr3.
    xk, yk : :py:`In(width)`
        End point (zero for a circle).
    tick : :py:`In(1)`
        Permission for the step due.
    stop : :py:`In(1)`
        End the running frame at the end of this clock.
    ready : :py:`Out(1)`
        A load is taken in this clock.
    error : :py:`Out(1)`
        A load was refused in this clock.
    due : :py:`Out(1)`
        A step waits for permission (the first clock of a step word).
    step : :py:`Out(2)`
        The step: bit 0 X, bit 1 Y.
    start : :py:`Out(1)`
        The initialisation ends in this clock: steps from the next.
    done : :py:`Out(1)`
        The frame ends in this clock.
    busy : :py:`Out(1)`
        A frame is loaded.
    running : :py:`Out(1)`
        A frame is making steps (after :py:`start`).

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, *, width=16):
        check_width("Register width", width, minimum=2)
        self._width = width
        word = word_length(width)
        self.pr1 = ShiftRegister(word)
        self.pr2 = ShiftRegister(word)
        self.pr3 = ShiftRegister(word)
        self.pr4 = ShiftRegister(word)
        self.pr5 = ShiftRegister(word)
        self.pr6 = ShiftRegister(1)
        self.pr7 = ShiftRegister(1)
        self.sm1 = SerialAdder()
        self.sm2 = SerialAdder()
        # The mode node's registers, reachable as attributes (tests sample them).
        self.phase = Signal(Phase, name="phase")
        self.bit = Signal(range(word), name="bit")
        super().__init__({
            "po":      In(1),
            "circle":  In(1),
            "x0":      In(width),
            "y0":      In(width),
            "f0":      In(signed(width + 1)),
            "xk":      In(width),
            "yk":      In(width),
            "tick":    In(1),
            "stop":    In(1),
            "ready":   Out(1),
            "error":   Out(1),
            "due":     Out(1),
            "step":    Out(2),
            "start":   Out(1),
            "done":    Out(1),
            "busy":    Out(1),
            "running": Out(1),
        })

    @property
    def width(self):
        return self._width

    @property
    def word(self):
        return word_length(self._width)

    def elaborate(self, platform):
        m = Module()
        word = self.word
        for name in ("pr1", "pr2", "pr3", "pr4", "pr5", "pr6", "pr7", "sm1", "sm2"):
            m.submodules[name] = getattr(self, name)
        pr1, pr2, pr3, pr4, pr5 = self.pr1, self.pr2, self.pr3, self.pr4, self.pr5
        pr6, pr7, sm1, sm2 = self.pr6, self.pr7, self.sm1, self.sm2

        # ---- mode node: phase, bit counter, mode trigger ---------------------------------
        phase, bit = self.phase, self.bit
        circle = Signal()                         # mode trigger: 1 circle, 0 line
        bit0 = Signal()
        last_bit = Signal()
        run = Signal()
        advance = Signal()                        # the rings turn by one bit in this clock
        stepping = Signal()
        m.d.comb += [
            bit0.eq(bit == 0),
            last_bit.eq(bit == word - 1),
            run.eq(phase == Phase.RUN),
            advance.eq((phase == Phase.INIT1) | (phase == Phase.INIT2)
                       | (run & (~bit0 | self.tick))),
            stepping.eq(run & bit0 & self.tick),
        ]
        axis = pr6.o                              # 1: the step of this word is along X

        # ---- См1: the selected coordinate, plus or minus one -------------------------------
        e1 = Signal()                             # Э1: Pr1 when the step is along X
        e2 = Signal()                             # Э2: Pr2 when it is along Y
        e3 = Signal()                             # Э3: minus one (all ones): X of a circle
        m.d.comb += [
            e1.eq(pr1.o & axis),
            e2.eq(pr2.o & ~axis),
            e3.eq(circle & axis & run),
            sm1.a.eq(e1 | e2),                    # Pr1 and Pr2 joined into one input
            sm1.b.eq(e3),
            sm1.ci.eq(run & ~e3),                 # plus one in a step word
            sm1.first.eq(bit0),
            sm1.en.eq(advance),
        ]

        # ---- См2: Q plus or minus the operand ---------------------------------------------
        # The operand is the new coordinate (circle) or the other axis's end coordinate (line:
        # Э4, Э5); in a step word it is doubled by Pr7's one-bit delay. For a Y step it enters
        # inverted (Э6) with a carry in (Э7): Q -= 2·operand; in the last initialisation word
        # inverted with no carry: Q += ~operand.
        e4 = Signal()                             # Э4: Pr5 (yk) when the step is along X
        e5 = Signal()                             # Э5: Pr4 (xk) when it is along Y
        raw = Signal()
        operand = Signal()
        e6 = Signal()                             # Э6: the operand inverted
        e7 = Signal()                             # Э7: carry into См2 for a subtraction
        m.d.comb += [
            e4.eq(pr5.o & axis),
            e5.eq(pr4.o & ~axis),
            raw.eq(Mux(circle, sm1.s, e4 | e5)),
            operand.eq(Mux(run, pr7.o, raw)),
            e6.eq(~operand),
            e7.eq(run & ~axis),
            sm2.a.eq(pr3.o),
            sm2.b.eq(Mux(axis, operand, e6)),
            sm2.ci.eq(e7),
            sm2.first.eq(bit0),
            sm2.en.eq(advance),
        ]

        # ---- the rings ---------------------------------------------------------------------
        new_x = Signal()
        new_y = Signal()
        m.d.comb += [
            new_x.eq(Mux(axis, sm1.s, pr1.o)),
            new_y.eq(Mux(axis, pr2.o, sm1.s)),
            pr1.i.eq(new_x),
            pr2.i.eq(new_y),
            pr3.i.eq(sm2.s),
            pr4.i.eq(pr4.o),
            pr5.i.eq(pr5.o),
            pr7.i.eq(raw),
            pr6.i.eq(Mux(phase == Phase.INIT1, 0, sm2.s)),    # the sign of the new Q
            pr6.en.eq(advance & last_bit),
        ]
        for register in (pr1, pr2, pr3, pr4, pr5, pr7):
            m.d.comb += register.en.eq(advance)

        # ---- end-of-frame node: the new coordinates against the end point -----------------
        mismatch = Signal()                       # a bit of this word differed so far
        mismatch_now = Signal()
        matched = Signal()
        ending = Signal()
        m.d.comb += [
            mismatch_now.eq(Mux(bit0, 0, mismatch) | (new_x ^ pr4.o)
                            | (~circle & (new_y ^ pr5.o))),
            matched.eq(advance & last_bit & ~mismatch_now
                       & ((phase == Phase.INIT2) | run)),
            ending.eq((run & self.stop) | matched),
        ]
        with m.If(advance):
            m.d.sync += mismatch.eq(mismatch_now)

        # ---- input mode (Ро) and the mode node's transitions -----------------------------
        load = Signal()
        m.d.comb += [
            self.ready.eq((phase == Phase.IDLE) | ending),
            load.eq(self.po & self.ready),
            self.error.eq(self.po & ~self.ready),
            pr1.d.eq(self.x0),
            pr2.d.eq(self.y0),
            pr3.d.eq(self.f0),                    # sign-extended to the word
            pr4.d.eq(self.xk),
            pr5.d.eq(self.yk),
            pr6.d.eq(self.circle),                # the first word adds x (circle) or ~xk
            pr7.d.eq(0),
        ]
        for register in (pr1, pr2, pr3, pr4, pr5, pr6, pr7):
            m.d.comb += register.load.eq(load)
        with m.If(load):
            m.d.sync += [bit.eq(0), circle.eq(self.circle),
                         phase.eq(Mux(self.circle, Phase.INIT1, Phase.INIT2))]
        with m.Else():
            with m.If(advance):
                m.d.sync += bit.eq(Mux(last_bit, 0, bit + 1))
            with m.If(ending):
                m.d.sync += phase.eq(Phase.IDLE)
            with m.Elif(advance & last_bit & (phase == Phase.INIT1)):
                m.d.sync += phase.eq(Phase.INIT2)
            with m.Elif(advance & last_bit & (phase == Phase.INIT2)):
                m.d.sync += phase.eq(Phase.RUN)

        # ---- output node ---------------------------------------------------------------------
        m.d.comb += [
            self.due.eq(run & bit0),
            self.step.eq(Cat(stepping & axis, stepping & ~axis)),
            self.start.eq((phase == Phase.INIT2) & last_bit),
            self.done.eq(ending),
            self.busy.eq(phase != Phase.IDLE),
            self.running.eq(run),
        ]
        return m


class _SerialCore(wiring.Component):
    """A :class:`SerialNode` as a core: the command is loaded by Ро straight into the node's
    registers while it is ready (the node holds no second command: :py:`cmd.ready` is low while
    a frame is in progress, and high again in the clock it ends); the permission is the node's
    :py:`tick`; :py:`abort` is its synchronous reset (no step in that clock)."""

    def __init__(self, signature, width):
        self.node = SerialNode(width=width)
        super().__init__(signature)

    @property
    def width(self):
        return self.node.width

    def _load(self, m, node):
        raise NotImplementedError

    def elaborate(self, platform):
        m = Module()
        node = self.node
        m.submodules.node = ResetInserter(self.abort)(node)
        enable = permit(m, self.feed, armed=1, running=node.due, abort=self.abort)
        self._load(m, node)
        m.d.comb += [
            node.tick.eq(enable),
            self.cmd.ready.eq(node.ready & ~self.abort),
            node.po.eq(self.cmd.valid & self.cmd.ready),
            self.feed.diagonal.eq(0),
            self.step.eq(node.step),
            self.start.eq(node.start),
            self.done.eq(node.done | (self.abort & node.running)),
            self.busy.eq(node.busy),
        ]
        return m


class SerialLineCore(_SerialCore):
    """:class:`SerialNode` as a line core (:class:`~kontur.hdl.line.LineCoreSignature`): the line to
    the magnitudes ``(x, y)`` is the node's frame ``x0 = y0 = 0``, ``xk = x``, ``yk = y``.

    A segment takes ``W`` clocks of initialisation, then ``W`` clocks per step at full feed
    (``W`` = :func:`word_length`); it ends ``W - 1`` clocks after its last step, and the next
    one may be taken in that clock.

    Parameters
    ----------
    width : :class:`int`
        As :class:`SerialNode`.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, *, width=16):
        check_width("Register width", width, minimum=2)
        super().__init__(LineCoreSignature(width), width)

    def _load(self, m, node):
        payload = self.cmd.payload
        m.d.comb += [node.circle.eq(0), node.x0.eq(0), node.y0.eq(0), node.f0.eq(payload.y),
                     node.xk.eq(payload.x), node.yk.eq(payload.y), node.stop.eq(0)]


class SerialArcCore(_SerialCore):
    """:class:`SerialNode` as a quadrant core (:class:`~kontur.hdl.arc.ArcCoreSignature`): the native
    run from ``(x, y)`` with ``residue`` is the node's circle frame ``x0 = x``, ``y0 = y``,
    ``f0 = residue``, ``xk = yk = 0``; :py:`stop` is the node's.

    A run takes ``2W`` clocks of initialisation, then ``W`` clocks per step at full feed.

    Parameters
    ----------
    width : :class:`int`
        As :class:`SerialNode`.

    Raises
    ------
    :exc:`TypeError`
        If ``width`` is not an integer of at least 2.
    """

    def __init__(self, *, width=24):
        check_width("Register width", width, minimum=2)
        super().__init__(ArcCoreSignature(width), width)

    def _load(self, m, node):
        payload = self.cmd.payload
        m.d.comb += [node.circle.eq(1), node.x0.eq(payload.x), node.y0.eq(payload.y),
                     node.f0.eq(payload.residue), node.xk.eq(0), node.yk.eq(0),
                     node.stop.eq(self.stop)]
