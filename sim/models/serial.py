"""Golden model of the textbook's two-coordinate linear-circular node, bit-serial, clock by clock.

The node (``kontur.hdl.serial.SerialNode``) interpolates with separate steps by the estimating
function at the midpoint (the trajectory of :mod:`kontur.sim.models.textbook`: ``separate_*``), one
bit of every register per clock. Its word is ``W = width + 2`` bits, least significant first;
every register is a ring of W bits that turns once a word.

Registers: Pr1 ``x``, Pr2 ``y`` (current coordinates), Pr3 ``Q`` (the estimating function,
``Q = -D - 1`` for a line, ``-G - 1`` for a circle, so that its sign bit is the decision: 1 ->
X step), Pr4 ``xk``, Pr5 ``yk`` (the end point; zero for a circle, whose run ends at X = 0),
Pr6 the axis of the step (1 X, 0 Y), Pr7 the one-bit delay that doubles an operand; the carry
flip-flops of the serial adders См1 (coordinate ± 1) and См2 (Q ± operand); the mode node
(phase, bit counter, mode trigger) and the end-of-frame node's mismatch flip-flop.

A frame is loaded by Ро (``po``), then one or two initialisation words form ``Q0``
(line: ``Pr3 = yk``, then ``Q += ~xk``; circle: ``Pr3 = residue``, ``Q += x``, ``Q += ~y``), then
each step word: its first clock waits for the permission and makes the step, the other
``W - 1`` run freely and form the new coordinate, the new Q (``Q ± 2·operand``), its sign (the
next axis) and the comparison with the end point.

:class:`SerialNodeModel` mirrors ``kontur.hdl.serial.SerialNode`` register for register;
:class:`SerialLineCoreModel` and :class:`SerialArcCoreModel` the cores around it.
"""

from .codes import mask
from .engine import permit
from .errors import InputError

__all__ = ["word_length", "IDLE", "INIT1", "INIT2", "RUN", "SerialNodeModel",
           "SerialLineCoreModel", "SerialArcCoreModel"]

IDLE, INIT1, INIT2, RUN = "Idle", "Init 1", "Init 2", "Run"


def word_length(width):
    """Bits in the node's word (and clocks per step) for ``width``-bit coordinates."""
    return width + 2


class SerialNodeModel:
    """Clock-by-clock model of :class:`kontur.hdl.serial.SerialNode`.

    With ``strict`` a load (Ро) while the node is not ready raises :exc:`InputError`; otherwise
    it is refused as the RTL refuses it, with the ``error`` output.
    """

    def __init__(self, width=16, *, strict=False):
        self.width = width
        self.word = word_length(width)
        self.strict = strict
        self.reset()

    def reset(self):
        """Return every register to its reset value (the RTL's synchronous reset)."""
        self.pr1 = self.pr2 = self.pr3 = self.pr4 = self.pr5 = 0
        self.pr6 = self.pr7 = 0
        self.carry1 = self.carry2 = 0
        self.mismatch = 0
        self.phase = IDLE
        self.bit = 0
        self.circle = 0
        self._version = 0                   # counts the changes of the registers (the cache)
        self._cache = None

    def state(self):
        return {"pr1": self.pr1, "pr2": self.pr2, "pr3": self.pr3, "pr4": self.pr4,
                "pr5": self.pr5, "pr6": self.pr6, "pr7": self.pr7, "bit": self.bit}

    def _gates(self, tick):
        """This clock's gates and next-bit values, without :py:`stop` (registers untouched).

        Cached until the registers change: the core models ask more than once a clock.
        """
        key = (self._version, bool(tick))
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        w = self.word
        phase = self.phase
        bit0 = self.bit == 0
        last_bit = self.bit == w - 1
        run = int(phase == RUN)
        advance = int(phase in (INIT1, INIT2) or (run and (not bit0 or bool(tick))))
        stepping = int(bool(run) and bit0 and bool(tick))
        o1, o2, o3, o4, o5 = (self.pr1 & 1, self.pr2 & 1, self.pr3 & 1, self.pr4 & 1,
                              self.pr5 & 1)
        pr6, circle = self.pr6, self.circle
        # См1: the selected coordinate (Э1, Э2 joined) plus 1, or minus 1 (Э3: all ones).
        e1 = o1 & pr6
        e2 = o2 & (1 - pr6)
        a1 = e1 | e2
        e3 = circle & pr6 & run                      # decrement: X of a circle
        cin1 = run & (1 - e3)
        c1 = cin1 if bit0 else self.carry1
        s1 = a1 ^ e3 ^ c1
        carry1 = (a1 & e3) | (a1 & c1) | (e3 & c1)
        # The operand: the new coordinate (circle) or the other end coordinate (line, Э4, Э5);
        # doubled through Pr7 in a step word; inverted (Э6) for a Y step; carry in (Э7) +1.
        e4 = o5 & pr6
        e5 = o4 & (1 - pr6)
        raw = s1 if circle else (e4 | e5)
        operand = self.pr7 if run else raw
        e6 = operand ^ (1 - pr6)
        e7 = run & (1 - pr6)
        c2 = e7 if bit0 else self.carry2
        s2 = o3 ^ e6 ^ c2
        carry2 = (o3 & e6) | (o3 & c2) | (e6 & c2)
        new_x = s1 if pr6 else o1
        new_y = o2 if pr6 else s1
        # End-of-frame node: the new coordinates against the end point (X only for a circle).
        differs = (new_x ^ o4) | ((1 - circle) & (new_y ^ o5))
        mismatch = (0 if bit0 else self.mismatch) | differs
        matched = int(bool(advance) and last_bit and not mismatch
                      and phase in (INIT2, RUN))
        gates = (advance, stepping, last_bit, s2, carry1, carry2, raw, new_x, new_y,
                 mismatch, matched)
        self._cache = (key, gates)
        return gates

    def outputs(self, *, po=0, tick=0, stop=0):
        """This clock's outputs (see :meth:`cycle`), leaving the model untouched."""
        gates = self._gates(tick)
        phase = self.phase
        ending = int((phase == RUN and bool(stop)) or bool(gates[10]))
        ready = int(phase == IDLE or bool(ending))
        pr6 = self.pr6
        return {"ready": ready, "error": int(bool(po) and not ready),
                "due": int(phase == RUN and self.bit == 0),
                "step": (pr6 | (1 - pr6) << 1) if gates[1] else 0,
                "start": int(phase == INIT2 and gates[2]), "done": ending,
                "busy": int(phase != IDLE), "running": int(phase == RUN)}

    def cycle(self, *, po=0, circle=0, x0=0, y0=0, f0=0, xk=0, yk=0, tick=0, stop=0):
        """One clock; returns ``(outputs, state)``, then advances.

        ``outputs``: ``ready``, ``error``, ``due``, ``step`` (bit 0 X, bit 1 Y), ``start``,
        ``done``, ``busy``, ``running``.
        """
        outputs = self.outputs(po=po, tick=tick, stop=stop)
        if po and not outputs["ready"] and self.strict:
            raise InputError("load (Ро) while a frame is in progress and not ending in this "
                             "clock: refused")
        state = self.state()
        (advance, _, last_bit, s2, carry1, carry2, raw, new_x, new_y, mismatch,
         _) = self._gates(tick)
        phase = self.phase
        load = bool(po) and bool(outputs["ready"])

        # ---- clock edge -------------------------------------------------------------------
        if advance:
            top = self.word - 1
            self.pr1 = (self.pr1 >> 1) | (new_x << top)
            self.pr2 = (self.pr2 >> 1) | (new_y << top)
            self.pr3 = (self.pr3 >> 1) | (s2 << top)
            self.pr4 = (self.pr4 >> 1) | ((self.pr4 & 1) << top)
            self.pr5 = (self.pr5 >> 1) | ((self.pr5 & 1) << top)
            self.pr7 = raw
            self.carry1, self.carry2 = carry1, carry2
            self.mismatch = mismatch
            if last_bit:
                self.pr6 = 0 if phase == INIT1 else s2
            self.bit = 0 if last_bit else self.bit + 1
        if load:
            w = self.word
            self.pr1, self.pr2 = x0 & mask(w), y0 & mask(w)
            self.pr3 = f0 & mask(w)
            self.pr4, self.pr5 = xk & mask(w), yk & mask(w)
            self.pr6, self.pr7 = int(bool(circle)), 0
            self.bit = 0
            self.circle = int(bool(circle))
            self.phase = INIT1 if circle else INIT2
        elif outputs["done"]:
            self.phase = IDLE
        elif advance and last_bit:
            self.phase = {INIT1: INIT2, INIT2: RUN, RUN: RUN}[phase]
        if advance or load or outputs["done"]:
            self._version += 1
        return outputs, state


class _SerialCoreModel:
    """A :class:`SerialNodeModel` as a core: the command loaded straight into the node (Ро)
    while it is ready, the permission as its tick, ``abort`` as its synchronous reset."""

    circle = 0

    def __init__(self, *, width=16):
        self.width = width
        self.node = SerialNodeModel(width)

    def reset(self):
        self.node.reset()

    def state(self):
        return self.node.state()

    def _load(self, payload):
        raise NotImplementedError

    def _inputs(self, tick, stop, abort, valid, payload):
        node = self.node
        due, enable = permit(tick, armed=1, running=int(node.phase == RUN and node.bit == 0),
                             abort=abort)
        out = node.outputs(tick=enable, stop=stop)
        inputs = {"tick": enable, "stop": stop, "circle": self.circle,
                  # Ро is the transfer: a command offered while the node is ready, no abort.
                  "po": int(bool(valid) and bool(out["ready"]) and not abort)}
        if payload is not None:
            inputs.update(self._load(payload))
        return due, inputs, out

    def _outputs(self, tick, stop, abort, valid, payload):
        node = self.node
        due, inputs, out = self._inputs(tick, stop, abort, valid, payload)
        running = node.phase == RUN
        return {"step": out["step"], "start": out["start"],
                "done": int(bool(out["done"]) or (bool(abort) and running)),
                "ready": int(bool(out["ready"]) and not abort), "busy": out["busy"],
                "due": due, "diagonal": 0}, inputs

    def evaluate(self, *, tick=1, stop=0, abort=0):
        """Outputs of this clock: ``step``, ``start``, ``done``, ``ready`` (of ``cmd``),
        ``busy``, ``due``, ``diagonal``."""
        return self._outputs(tick, stop, abort, 0, None)[0]

    def cycle(self, *, tick=1, stop=0, abort=0, valid=0, payload=None):
        """One clock with the command ``payload`` offered if ``valid``; returns ``(outputs,
        state)``, then advances."""
        outputs, inputs = self._outputs(tick, stop, abort, valid, payload)
        state = self.state()
        if abort:
            self.node.reset()
        else:
            self.node.cycle(**inputs)
        return outputs, state


class SerialLineCoreModel(_SerialCoreModel):
    """Model of :class:`kontur.hdl.serial.SerialLineCore`: the node in line mode."""

    circle = 0

    def _load(self, payload):
        return {"x0": 0, "y0": 0, "f0": payload["y"], "xk": payload["x"], "yk": payload["y"]}


class SerialArcCoreModel(_SerialCoreModel):
    """Model of :class:`kontur.hdl.serial.SerialArcCore`: the node in circle mode."""

    circle = 1

    def _load(self, payload):
        return {"x0": payload["x"], "y0": payload["y"], "f0": payload["residue"], "xk": 0,
                "yk": 0}

    def peek(self, *, tick=1, abort=0):
        """This clock's native step (it does not depend on ``stop``)."""
        return self.evaluate(tick=tick, abort=abort)["step"]
