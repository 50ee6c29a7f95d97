"""The cycle level (:class:`EquidistantEngineModel`): :class:`kontur.hdl.equidistant.EquidistantEngine`
clock for clock."""

from types import SimpleNamespace

from kontur.hdl.spec import SETTLE

from ..arc import direction_bits, quadrant, type_a
from ..engine import StatusModel
from .functions import DONE_CODE, KIND, REFUSED_CODE, Formats, _frame_defaults

__all__ = ["EquidistantEngineModel"]


class EquidistantEngineModel:
    """Clock-by-clock model of :class:`kontur.hdl.equidistant.EquidistantEngine` around a quadrant
    core model (:class:`~kontur.sim.models.circular.FastArcCoreModel` or
    :class:`~kontur.sim.models.circular.FaithfulArcCoreModel` of width ``width + 2``).

    Registers as the RTL has them: the three slots of block 2 (``None`` when empty), the
    position counters (blocks 12, 13), the radius and r², the start, the product unit
    (blocks 5-8: its state, the frame being formed, the position it is formed at, the clocks
    left), the arc run (state, swap, directions), the contour and return flags, the status
    unit. Where the RTL keeps a sum in registers that no output sees (the slots a clock behind
    the position, their relative positions, the return's difference, block 11's stages) the
    model keeps the value it stands for: its slots are stepped in the clock of the step, and
    block 11's test is delayed SETTLE clocks, the clocks the RTL needs after a step. Call
    :meth:`cycle` once per clock.
    """

    def __init__(self, core, *, fraction=None, number_width=8):
        self.core = core
        self.formats = Formats(core.width - 2, fraction)
        self.width = self.formats.width
        self.status = StatusModel(position_width=self.width + 3, number_width=number_width)
        self.reset()

    def reset(self):
        self.core.reset()
        self.status.reset()
        self.own = self.cmp = self.prep = None
        self.x = self.y = 0
        self.radius = self.radius2 = 0
        self.start = (0, 0)
        self.contour = 0
        self.homing = 0
        self.unit = 0
        self.left = 0
        self.pending = None
        self.p0 = (0, 0)
        self.arc_state = 0
        self.run_swap = 0
        self.run_dir = 0
        self.product = 0                  # block 6's last product (r² is taken from it)
        self.quiet = [0] * SETTLE         # the clocks before changed nothing (the last first)
        # Block 11's test (the element ends at the point) of the state SETTLE clocks before:
        # in the RTL the slots a clock behind the position, then the test's two stages.
        self.tests = [0] * SETTLE

    def state(self):
        return {"x": self.x, "y": self.y, "unit": self.unit, "arc_state": self.arc_state}

    # -- the functions of a slot --

    def _coefficients(self, swap, minor, k):
        one = self.formats.one
        sk, sone = (-k, -one) if minor else (k, one)
        return (-sone, sk) if swap else (sk, -sone)

    def _stepped(self, s, dx, dy):
        c, d = self._coefficients(s["swap"], s["minor"], s["k"])
        ec, ed = self._coefficients(s["eswap"], s["eminor"], s["ek"])
        if s["arc"]:
            u, v = self.x - s["cx"], self.y - s["cy"]
            dv = (2 * u * dx + 1 if dx else 0) + (2 * v * dy + 1 if dy else 0)
        else:
            dv = c * dx + d * dy
        return s["v"] + dv, s["w"] + ec * dx + ed * dy

    def _line_value(self, frame, second, base):
        one = self.formats.one
        bx, by = base
        if second:
            swap, minor, k, b, g = (frame["eswap"], frame["eminor"], frame["ek"], frame["eb"],
                                    frame["eg"])
        else:
            swap, minor, k, b = frame["swap"], frame["minor"], frame["k"], frame["b"]
            g = frame["side"] * frame["sec"]
        raw = (k * by + b - bx * one - g * self.radius if swap
               else k * bx + b - by * one + g * self.radius)
        return -raw if minor else raw

    def _circle_value(self, frame, base):
        f = self.formats
        u, v = base[0] - frame["x"], base[1] - frame["y"]
        rounded = (frame["g"] * self.radius + (f.one >> 1)) >> f.fraction
        sigma = 1 if (frame["side"] == 1) == bool(frame["cw"]) else -1
        n = frame["e"] + self.radius2 + sigma * rounded
        return u * u + v * v - n, n

    def cycle(self, *, valid=0, payload=None, tick=1, abort=0, status_ready=1):
        """One clock: the outputs of this clock (before the edge) and :meth:`state`; then the
        clock edge. ``c`` carries this clock's values from one block group to the next, under
        the RTL's names."""
        c = SimpleNamespace(valid=valid, frame=_frame_defaults(payload), tick=tick, abort=abort,
                            x=self.x, y=self.y, own=self.own, cmp=self.cmp, prep=self.prep,
                            hold=self.status.hold)
        own, cmp = c.own, c.cmp
        c.running = int(own is not None and not own["last"] and own["ready"]
                        and cmp is not None and cmp["ready"] and all(self.quiet)
                        and not c.hold and not abort)
        self._block3(c)
        self._block11_threshold(c)
        self._block9_steps(c)
        self._element_ends(c)
        self._block1_frames(c)
        outputs = self._blocks14_15_outputs(c, status_ready)
        state = self.state()
        self._edge_arc_runs(c)
        self._edge_block2_memory(c)
        self._edge_blocks5_8(c)
        self._edge_control(c)
        self.tests = [c.at_point] + self.tests[:-1]
        # (The functions formed into the slot after them change neither.)
        formed_here = (c.combine1 or c.combine2) and any(
            s is not None and s["computing"] for s in (c.own, c.cmp))
        self.quiet = [int(not c.step_x and not c.step_y and not c.shift_cmp and not formed_here
                          and not abort)] + self.quiet[:-1]
        return outputs, state

    def _block3(self, c):
        """Block 3: the traced line's step kinds (register I ``|k|``, register III ``v``)."""
        own, half = c.own, self.formats.one >> 1
        c.line = {}
        if own is not None:
            reg1 = abs(own["k"])
            minor_only = own["v"] >= half
            ahead = own["v"] + reg1
            forward = not minor_only and ahead >= half
            backward = not minor_only and ahead < -half
            c.line = {"major": int(not minor_only),
                      "minor": int(minor_only or forward or backward),
                      "minor_negative": int(bool(own["minor"]) != backward)}

    def _block11_threshold(self, c):
        """Block 11: the kinds of the traced element's steps, the target's threshold ``2τ``,
        whether the element ends at the point (``at_point``, through SETTLE registers), and
        its end now (``end_now``: by the test of SETTLE clocks before, of this state while
        the clocks since changed nothing)."""
        own, cmp, x, y = c.own, c.cmp, c.x, c.y
        c.tau2 = 0
        c.quadrant_own = 0
        if own is not None:
            ou, ov = x - own["cx"], y - own["cy"]
            c.quadrant_own = quadrant(ou, ov, own["cw"])
        if own is not None and cmp is not None:
            x_negative = c.quadrant_own in (1, 2)
            y_negative = c.quadrant_own in (2, 3)
            if own["arc"]:
                qxn = y_negative if own["cw"] else not y_negative
                qyn = (not x_negative) if own["cw"] else x_negative
            else:
                qxn = own["minor"] if own["swap"] else own["back"]
                qyn = own["back"] if own["swap"] else own["minor"]
            x_kind = own["arc"] or not own["swap"]
            y_kind = own["arc"] or own["swap"]
            qx, qy = -1 if qxn else 1, -1 if qyn else 1
            if cmp["arc"] and not cmp["entry"]:
                tu, tv = x - cmp["cx"], y - cmp["cy"]
                ka, kb = 2 * tu * qx + 1, 2 * tv * qy + 1
            else:
                if cmp["entry"]:
                    tc, td = self._coefficients(cmp["eswap"], cmp["eminor"], cmp["ek"])
                else:
                    tc, td = self._coefficients(cmp["swap"], cmp["minor"], cmp["k"])
                ka, kb = tc * qx, td * qy
            c.tau2 = max(abs(ka) if x_kind else 0, abs(kb) if y_kind else 0, abs(ka + kb))
        c.at_point = 0
        if own is not None and cmp is not None:
            target = cmp["w"] if cmp["entry"] else cmp["v"]
            at_centre = own["arc"] and (x, y) == (own["cx"], own["cy"])
            c.at_point = int(self._reached(c, target)
                             or bool(own["arc"] and (own["empty"] or at_centre)))
        c.end_now = int(bool(c.running) and bool(self.tests[-1]))

    def _reached(self, c, value):
        """Block 11's comparison: the target function ``value`` has reached the element's end."""
        return (2 * (-value if c.cmp["h"] else value) + c.tau2) >= 0

    def _block9_steps(self, c):
        """This clock's step: the line's (block 3), the arc core's or the return's, onto the
        real axes (block 9)."""
        own, x, y, tick, abort = c.own, c.x, c.y, c.tick, c.abort
        c.line_due = int(c.running and not c.end_now and not own["arc"])
        line_step = int(c.line_due and bool(tick))
        c.arc_go = int(c.running and not c.end_now and bool(own["arc"]))
        c.core_tick = int(bool(tick) and c.arc_go)
        c.core_abort = int(bool(abort) or (own is not None and own["arc"] and c.end_now))
        native = self.core.peek(tick=c.core_tick, abort=c.core_abort)
        arc_bits = ((native & 1) << 1 | native >> 1) if self.run_swap else native
        c.home_dx, c.home_dy = int(x != self.start[0]), int(y != self.start[1])
        c.home_due = int(bool(self.homing) and bool(c.home_dx or c.home_dy) and not c.hold
                         and not abort)
        c.home_step = int(c.home_due and bool(tick))

        step_x = step_y = neg_x = neg_y = 0
        if line_step:
            if own["swap"]:
                step_x, neg_x = c.line["minor"], c.line["minor_negative"]
                step_y, neg_y = c.line["major"], own["back"]
            else:
                step_x, neg_x = c.line["major"], own["back"]
                step_y, neg_y = c.line["minor"], c.line["minor_negative"]
        elif c.home_step:
            step_x, neg_x = c.home_dx, int(x > self.start[0])
            step_y, neg_y = c.home_dy, int(y > self.start[1])
        elif c.arc_go:
            step_x, neg_x = arc_bits & 1, self.run_dir & 1
            step_y, neg_y = arc_bits >> 1 & 1, self.run_dir >> 1 & 1
        c.step_x, c.step_y, c.neg_x, c.neg_y = step_x, step_y, neg_x, neg_y
        c.dx = (-1 if neg_x else 1) if step_x else 0
        c.dy = (-1 if neg_y else 1) if step_y else 0

    def _element_ends(self, c):
        """Blocks 4 and 10 over this clock's step; block 2's shifts."""
        own, cmp = c.own, c.cmp
        c.slots = [own, cmp, c.prep]
        c.stepped_vw = [self._stepped(s, c.dx, c.dy) if s is not None else (0, 0)
                        for s in c.slots]
        # The core's stop is unused: block 11 ends an arc's run at the point (abort).
        c.core_out = self.core.evaluate(tick=c.core_tick, stop=0, abort=c.core_abort)

        c.element_end = c.end_now
        c.terminal_end = int(own is not None and bool(own["last"]) and not c.hold
                             and not c.abort)
        c.shift_own = int(bool(c.element_end) or bool(c.terminal_end) or own is None)
        c.shift_cmp = int(bool(c.shift_own) or cmp is None)

    def _block1_frames(self, c):
        """Block 1: the frame offered, checked, taken or refused; the control frames' ends."""
        frame, valid, status = c.frame, c.valid, self.status
        kind = frame["kind"]
        is_element = kind in (KIND["line"], KIND["arc"])
        bad = (kind > KIND["close"] or (is_element and not self.contour)
               or (kind == KIND["radius"] and frame["x"] < 0))
        c.combine1 = self.unit == 2 and self.left == 0
        c.combine2 = self.unit == 4 and self.left == 0
        last_round = (c.combine1 and not self.pending["entry"]) or c.combine2 if self.pending \
            else False
        engine_idle = (c.own is None and c.cmp is None and c.prep is None and self.unit == 0
                       and not self.homing and not self.contour)
        accepting = not c.abort and not status.flushing
        c.take_element = (accepting and bool(self.contour) and is_element
                          and c.prep is None and (self.unit == 0 or bool(last_round)))
        take_control = accepting and not is_element and not bad and engine_idle and \
            bool(status.idle)
        c.refuse = int(bool(valid) and accepting and bool(bad) and engine_idle
                       and bool(status.idle))
        c.ready = c.refuse if bad else int(bool(c.take_element) if is_element
                                           else bool(take_control))
        c.accept = int(bool(valid) and bool(c.ready))

        c.kind = kind
        c.taken = c.accept and not bad
        c.start_now = int(c.taken and kind == KIND["start"])
        c.close_now = int(c.taken and kind == KIND["close"])
        c.close_end = int((c.close_now and not c.home_dx and not c.home_dy)
                          or (c.home_step and (c.x + c.dx, c.y + c.dy) == self.start))
        c.radius_end = int(self.unit == 5 and self.left == 0)

    def _blocks14_15_outputs(self, c, status_ready):
        """Blocks 14 and 15: the step permission (the feed interface); motion; outcomes."""
        step_x, step_y, neg_x, neg_y = c.step_x, c.step_y, c.neg_x, c.neg_y
        status = self.status
        arc_due = int(bool(c.core_out["due"]) and bool(c.arc_go))
        due = int(bool(c.line_due) or bool(arc_due) or bool(c.home_due))
        if c.line_due:
            diagonal = int(bool(c.line["major"]) and bool(c.line["minor"]))
        elif c.home_due:
            diagonal = int(bool(c.home_dx) and bool(c.home_dy))
        else:
            diagonal = int(c.core_out["diagonal"])
        diagonal = int(bool(due) and bool(diagonal))
        end = int(bool(c.element_end) or bool(c.terminal_end) or bool(c.start_now)
                  or bool(c.close_end) or bool(c.radius_end) or bool(c.refuse))
        step_bits = step_x | step_y << 1
        stream = status.evaluate(step=step_bits, direction=neg_x | neg_y << 1, end=end,
                                 outcome=REFUSED_CODE if c.refuse else DONE_CODE,
                                 status_ready=status_ready)
        return {"ready": c.ready, "step": step_bits,
                "dir": (step_x & neg_x) | (step_y & neg_y) << 1, "busy": status.busy,
                "due": due, "diagonal": diagonal,
                "status": stream["payload"] if stream["transfer"] else None}

    # ---- clock edge -----------------------------------------------------------------------

    def _edge_arc_runs(self, c):
        """The arc core's clock (a run handed over in WAIT) and the arc run's state."""
        own = c.own
        c.core_valid = int(bool(c.arc_go) and self.arc_state == 0)
        run = None
        if c.core_valid:
            q = c.quadrant_own
            u, v = c.x - own["cx"], c.y - own["cy"]
            run = {"x": abs(u) if type_a(q, own["cw"]) else abs(v),
                   "y": abs(v) if type_a(q, own["cw"]) else abs(u), "residue": -own["v"]}
        self.core.cycle(tick=c.core_tick, stop=0, abort=c.core_abort,
                        valid=c.core_valid, payload=run)
        if c.abort or c.element_end:
            self.arc_state = 0
        elif self.arc_state == 0 and c.core_valid:
            q = c.quadrant_own
            self.arc_state = 1
            self.run_swap = int(not type_a(q, own["cw"]))
            self.run_dir = direction_bits(q, own["cw"])
        elif self.arc_state == 1:
            self.arc_state = 2
        elif self.arc_state == 2 and c.core_out["done"]:
            self.arc_state = 0

    def _edge_block2_memory(self, c):
        """Block 2's next contents: every slot stepped, its functions added when formed
        (blocks 7, 8), the slots shifted, a new frame taken into the last."""
        values = {}
        if self.unit in (2, 4) and self.left == 0:
            second = self.unit == 4
            if self.pending["kind"] == KIND["arc"] and not second:
                values["circle"] = self._circle_value(self.pending, self.p0)
            values["line"] = self._line_value(self.pending, second, self.p0)

        def advanced(n):
            s = c.slots[n]
            if s is None:
                return None
            s = dict(s)
            s["v"], s["w"] = c.stepped_vw[n]
            if s["computing"] and c.combine1:
                if s["arc"]:
                    value, big_n = values["circle"]
                    s["v"] += value
                    s["empty"] = int(big_n <= 0)
                else:
                    s["v"] += values["line"]
                if not self.pending["entry"]:
                    s["computing"], s["ready"] = 0, 1
            if s["computing"] and c.combine2:
                s["w"] += values["line"]
                s["computing"], s["ready"] = 0, 1
            return s

        moved = [advanced(n) for n in range(3)]
        if c.abort:
            self.own = self.cmp = self.prep = None
        else:
            self.own = moved[1] if c.shift_own else moved[0]
            self.cmp = moved[2] if c.shift_cmp else moved[1]
            # A frame is taken into the last slot when it is empty at the clock's start.
            if c.prep is None:
                self.prep = _new_slot(c.frame) if (c.take_element and c.valid) else None
            else:
                self.prep = None if c.shift_cmp else moved[2]

    def _edge_blocks5_8(self, c):
        """Blocks 5-8: the product unit's state, the radius and r², the frame being formed."""
        frame, x, y = c.frame, c.x, c.y
        length = self.width + 2
        if c.abort:
            self.unit = 0
        elif self.unit == 0:
            if c.taken and c.kind == KIND["radius"]:
                # The product starts a clock after the frame (its operands registered).
                self.unit, self.radius, self.left = 5, frame["x"], length + 1
                self.product = frame["x"] * frame["x"]
        elif self.unit == 1:
            # The products start a clock after the launch (their operands registered) and
            # take ``length`` clocks, their sums two more (registered).
            self.unit, self.p0, self.left = 2, (x, y), length + 3
        elif c.combine1:
            self.unit = 3 if self.pending["entry"] else 0
        elif self.unit == 3:
            self.unit, self.left = 4, length + 3
        elif c.combine2:
            self.unit = 0
        elif self.unit == 5 and self.left == 0:
            self.unit, self.radius2 = 0, self.product
        elif self.left:
            self.left -= 1
        if c.take_element and c.valid and not c.abort:
            self.pending, self.unit = frame, 1

    def _edge_control(self, c):
        """Control frames (the contour, the return) and blocks 12, 13 (the position)."""
        frame = c.frame
        if c.abort:
            self.contour = self.homing = 0
        else:
            if c.start_now:
                self.contour, self.start = 1, (frame["x"], frame["y"])
            if c.take_element and c.valid and frame["last"]:
                self.contour = 0
            if c.close_now and not c.close_end:
                self.homing = 1
            if c.close_end:
                self.homing = 0
        if c.start_now:
            self.x, self.y = frame["x"], frame["y"]
        else:
            self.x, self.y = c.x + c.dx, c.y + c.dy
        self.status.advance(accept=c.accept, flush=c.abort)


def _new_slot(frame):
    return {"valid": 1, "ready": 0, "computing": 1, "last": frame["last"],
            "arc": int(frame["kind"] == KIND["arc"]), "h": frame["h"], "entry": frame["entry"],
            "empty": 0, "swap": frame["swap"], "minor": frame["minor"],
            "back": int(frame["sec"] < 0), "k": frame["k"], "cx": frame["x"], "cy": frame["y"],
            "cw": frame["cw"], "eswap": frame["eswap"], "eminor": frame["eminor"],
            "ek": frame["ek"], "v": 0, "w": 0}
