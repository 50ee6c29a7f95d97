"""Step/dir stage: an engine's one-clock steps re-timed for stepper drivers."""

from amaranth import *
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width
from ..engine import MotionSignature

__all__ = ["StepDirStage"]


class StepDirStage(wiring.Component):
    """Step pulses ``step_width`` clocks long, each with its direction set up before it.

    An engine's step pulses last one clock and its directions change in the clock of a step:
    too fast for a stepper driver. Here, for each axis, a step in clock ``k`` latches the
    engine's direction onto the output in clock ``k + 1`` and drives the step output high in
    clocks ``k + 1 + dir_setup`` to ``k + dir_setup + step_width``: the direction is set up
    ``dir_setup`` clocks before the rising edge and held until the axis's next step. Steps of
    one axis must therefore come at least ``dir_setup + step_width + 1`` clocks apart.

    :py:`halt` stops the pins at once without a runt pulse: while it is high a step still in
    its direction set-up is dropped, a step offered is not taken, and a pulse already on the
    pin is finished (its full ``step_width``). So the last rising edge of a step output comes
    in the first clock of :py:`halt` at the latest. :py:`made` marks every pulse that reaches
    its pin (high in its first clock, with its direction on :py:`o.dir`): the steps actually
    made, from which the controller counts its position.

    Parameters
    ----------
    axes : :class:`int`
        Number of axes.
    dir_setup : :class:`int`
        Clocks from a direction change to the rising edge of the step pulse (0 or more).
    step_width : :class:`int`
        Length of a step pulse in clocks.

    Members
    -------
    i : :py:`In(MotionSignature(axes))`
        The engine's motion.
    o : :py:`Out(MotionSignature(axes))`
        The re-timed step and direction outputs.
    halt : :py:`In(1)`
        No new pulse (see above).
    made : :py:`Out(axes)`
        A pulse begins on the axis's step output in this clock.
    idle : :py:`Out(1)`
        No step in its set-up, on a pin or coming in: every pulse so far is over.

    Raises
    ------
    :exc:`TypeError`
        If ``dir_setup`` is not a non-negative integer or ``step_width`` not a positive one.
    """

    def __init__(self, *, axes=2, dir_setup=0, step_width=1):
        check_width("Direction setup", dir_setup, minimum=0)
        check_width("Step pulse width", step_width)
        self._dir_setup = dir_setup
        self._step_width = step_width
        super().__init__({"i": In(MotionSignature(axes)), "o": Out(MotionSignature(axes)),
                          "halt": In(1), "made": Out(axes), "idle": Out(1)})

    @property
    def dir_setup(self):
        return self._dir_setup

    @property
    def step_width(self):
        return self._step_width

    def elaborate(self, platform):
        m = Module()
        setup, width = self._dir_setup, self._step_width
        busy = []
        for axis in range(self.i.signature.axes):
            left = Signal(range(setup + width + 1), name=f"left_{axis}")
            with m.If(self.halt & (left > width)):
                m.d.sync += left.eq(0)              # still in its set-up: dropped
            with m.Elif(self.i.step[axis] & ~self.halt):
                m.d.sync += [
                    left.eq(setup + width),
                    self.o.dir[axis].eq(self.i.dir[axis]),
                ]
            with m.Elif(left != 0):
                m.d.sync += left.eq(left - 1)
            m.d.comb += [self.o.step[axis].eq((left != 0) & (left <= width)),
                         self.made[axis].eq(left == width)]
            busy.append(left != 0)
        m.d.comb += self.idle.eq(~Cat(*busy).any() & ~self.i.step.any())
        return m
