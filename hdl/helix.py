"""Helical arcs: an arc in XY with Z spread evenly over the arc's steps.

:class:`HelixEngine` wraps an :class:`~kontur.hdl.arc.ArcEngine` and follows its motion: the
arc's XY steps are the plain arc's, untouched, and each of them may carry a Z step in the same
clock. Which of them does is Bresenham's rule over the arc's step count ``n`` (the number of
clocks with an XY step, which the host knows exactly from the arc model): every XY step adds
``|z|`` to an accumulator, and a Z step is made when it passes ``n``. The accumulator starts at
``⌊n/2⌋``, so after ``k`` XY steps Z has made ``⌊(⌊n/2⌋ + k|z|)/n⌋`` steps, within half a step of
``k·|z|/n``, and after the ``n``-th exactly ``|z|``.

The arc may lie in any of the three planes (G17, G18, G19): the frame's ``plane`` says which
machine axes the arc's native coordinates ``(a, b)`` and its linear axis ``c`` are, as
LinuxCNC's and Grbl's canonical arcs name them (the plane's first and second axis, then the
axis normal to it): 0 (G17) ``(X, Y, Z)``, 1 (G18) ``(Z, X, Y)``, 2 (G19) ``(Y, Z, X)``. A
clockwise arc is clockwise in ``(a, b)`` in each: looking down the normal axis from its
positive side. Machine axis ``k`` is native axis ``(k + plane) mod 3``, a rotation of the
step, direction and position outputs and nothing else: the steps themselves are the G17
helix's.
"""

from amaranth import *
from amaranth.lib import data, wiring

from .arc import ArcEngine
from .elements import magnitude
from .engine import EngineSignature, Outcome, step_delta

__all__ = ["HelixEngine"]


class HelixEngine(wiring.Component):
    """Helices in, step/dir on X, Y, Z out: an arc engine with Z following its steps.

    Each transfer on :py:`cmd` is an arc frame (:class:`~kontur.hdl.arc.ArcEngine`'s ``x0``,
    ``y0``, ``x1``, ``y1``, ``cw``) with ``z``, the Z move (signed steps), ``n``, the arc's
    step count, and ``plane`` (0, 1, 2: G17, G18, G19; the fields named X, Y, Z are then the
    plane's first, second and normal axis, see above). The engine takes one helix at a time
    (:py:`cmd.ready` is low from a helix's acceptance to its outcome's transfer), hands the arc to
    the arc engine in that same transfer (the arc fields are the arc engine's frame: no register
    holds them) and lets the Z steps ride on its XY steps (one-clock pulses on ``motion.step[2]``,
    with ``motion.dir[2]`` the sign of ``z`` from the acceptance on). :py:`feed.diagonal` is the arc
    engine's plus one when the waiting step carries a Z step: its length class (1, √2, √3).

    A helix with ``|z| > n`` (more than one Z step per XY step), or with ``plane`` 3, is refused
    (:attr:`~kontur.hdl.engine.Outcome.REFUSED`, nothing moves) before the arc starts; an arc the
    arc engine refuses is refused likewise, with no Z step. The outcome's position is the arc
    engine's X and Y and the Z steps made. :py:`abort` goes to the arc engine; a refused helix
    whose outcome is not yet taken ends :attr:`~kontur.hdl.engine.Outcome.ABORTED` instead.

    Parameters
    ----------
    arc : :class:`~kontur.hdl.arc.ArcEngine`
        The arc engine (becomes the submodule ``arc``); its register width ``w`` sets the width
        of ``n`` (``w + 4`` bits: an arc has fewer than ``8·2**w + 8`` steps) and of the status
        positions (``w + 5`` bits).
    """

    @staticmethod
    def Frame(coord_width, count_width):
        fields = dict(ArcEngine.Frame(coord_width).members)
        return data.StructLayout({**fields, "z": signed(max(coord_width, count_width + 1)),
                                  "n": unsigned(count_width), "plane": unsigned(2)})

    def __init__(self, arc):
        if not isinstance(arc, ArcEngine):
            raise TypeError(f"Arc must be an ArcEngine, not {arc!r}")
        self._arc = arc
        self._count_width = arc.width + 4
        super().__init__(EngineSignature(self.Frame(arc.coord_width, self._count_width),
                                         axes=3, position_width=self._count_width + 1))

    @property
    def arc(self):
        return self._arc

    @property
    def width(self):
        return self._arc.width

    @property
    def count_width(self):
        return self._count_width

    def _z_unit(self, m, accept):
        """The Z move's registers, loaded at acceptance, and its step: ``(step, next)``."""
        cw = self._count_width
        p = self.cmd.payload
        z_magnitude, z_wide = magnitude(m, p.z, cw)
        rate = Signal(cw, name="z_rate", reset_less=True)            # |z|
        back = Signal(signed(cw + 1), name="z_back", reset_less=True)  # |z| - n
        # |z| - n + (accumulator): Z steps at the next XY step when it is not negative.
        ahead = Signal(signed(cw + 2), name="z_ahead")
        moves = Signal(name="z_moves")
        sign = Signal(name="z_dir")
        # One subtraction gives the increment of a Z step, the accumulator's start and the
        # check that Z moves at most one step per XY step.
        difference = Signal(signed(cw + 1))
        m.d.comb += difference.eq(z_magnitude - p.n)
        with m.If(accept):
            m.d.sync += [
                rate.eq(z_magnitude),
                back.eq(difference),
                ahead.eq(difference + (p.n >> 1)),
                moves.eq(p.z.any()),
                sign.eq(p.z[-1]),
            ]
        refused = Signal()
        m.d.comb += refused.eq(z_wide | (~difference[-1] & difference.any())
                               | (p.plane == 3))
        xy = Signal()
        coming = Signal()
        m.d.comb += [
            xy.eq(self._arc.motion.step.any()),
            coming.eq(moves & ~ahead[-1]),
        ]
        with m.If(xy & ~accept):
            m.d.sync += ahead.eq(ahead + Mux(ahead[-1], rate, back))
        return xy & coming, coming, sign, refused

    def elaborate(self, platform):
        m = Module()
        m.submodules.arc = arc = self._arc
        pw = self.signature.position_width

        active = Signal()       # a helix was accepted whose outcome has not been transferred
        own = Signal()          # ... and its outcome is given here (refused, or then aborted)
        own_outcome = Signal(Outcome)
        number = Signal(self.signature.number_width)
        moved = Signal(signed(pw))   # Z steps made by the running helix, before this clock

        # A helix goes to the arc engine in the clock it is accepted (the arc fields are the
        # arc engine's frame), unless it is refused here; then its outcome is given here.
        accept = Signal()
        z_step, z_coming, z_dir, refused = self._z_unit(m, accept)
        m.d.comb += [
            arc.cmd.valid.eq(self.cmd.valid & ~active & ~refused & ~self.abort),
            *(arc.cmd.payload[name].eq(self.cmd.payload[name])
              for name in ArcEngine.Frame(arc.coord_width).members),
            # (A refused helix is taken when the arc engine could take it, as it always can
            # when no helix is active but while it reports an abort: so cmd.ready does not
            # wait for the check.)
            self.cmd.ready.eq(~active & ~self.abort & arc.cmd.ready),
            accept.eq(self.cmd.valid & self.cmd.ready),
        ]
        with m.If(accept):
            m.d.sync += [active.eq(1), own.eq(refused), own_outcome.eq(Outcome.REFUSED)]
        with m.If(self.abort & own):
            m.d.sync += own_outcome.eq(Outcome.ABORTED)

        own_valid = Signal()
        z_position = Signal(signed(pw))
        m.d.comb += [
            own_valid.eq(active & own & ~self.abort),
            z_position.eq(moved + step_delta(z_step, z_dir)),
            self.status.valid.eq(own_valid | arc.status.valid),
            arc.status.ready.eq(self.status.ready),
            self.status.p.number.eq(number),
            self.status.p.outcome.eq(Mux(own_valid, own_outcome, arc.status.p.outcome)),
        ]
        # The plane, kept from the acceptance to the outcome (no helix is taken before the
        # outcome of the one before is transferred), rotates the native axes onto the
        # machine's: machine axis k is native axis (k + plane) mod 3.
        plane = Signal(2, name="plane")
        with m.If(accept):
            m.d.sync += plane.eq(self.cmd.payload.plane)

        def rotated(native):        # the machine's axes X, Y, Z from the native three
            return [Mux(plane == 1, native[(k + 1) % 3],
                        Mux(plane == 2, native[(k + 2) % 3], native[k])) for k in range(3)]

        # A refused helix's position needs no multiplexer: the arc engine is idle and reads
        # zero then (its counters were cleared by the transfer before this helix was taken,
        # at least two clocks ago), and no Z step was made.
        position = rotated([arc.status.p.position[0], arc.status.p.position[1], z_position])
        m.d.comb += [self.status.p.position[k].eq(position[k]) for k in range(3)]
        m.d.sync += moved.eq(z_position)
        with m.If(self.status.valid & self.status.ready):
            m.d.sync += [active.eq(0), own.eq(0), number.eq(number + 1), moved.eq(0)]

        m.d.comb += [
            arc.feed.tick.eq(self.feed.tick),
            self.feed.due.eq(arc.feed.due),
            self.feed.diagonal.eq(arc.feed.diagonal + z_coming),
            arc.abort.eq(self.abort),
            self.motion.step.eq(Cat(*rotated([*arc.motion.step, z_step]))),
            self.motion.dir.eq(Cat(*rotated([*arc.motion.dir, z_dir]))),
            self.busy.eq(active),
        ]
        return m
