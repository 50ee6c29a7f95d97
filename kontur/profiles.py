"""Compensated profiles written the way a CAM post writes them: the corpus of
``tests/programs/comp/`` (tests/programs/SOURCES.md; ``python -m kontur.profiles`` writes it
again) and random ones (:func:`random_programs`, ``python -m kontur.bench compensation
--random N``). Each is a 2D profile of lines and arcs written the way
a CAM post writes one: a rapid to a point off the part, G41/G42 with an entry line to the
profile's first point, the profile (closed), G40 with an exit line, in mm or inches, with the
cutter's diameter given in the program (G41.1/G42.1 D). Coordinates are rotated and moved off
the lattice of round numbers, so that tangent joints are tangent only up to the rounding
of four decimals (as a CAM post writes them)."""

import math
import random
from pathlib import Path

#: Where the corpus is.
CORPUS = Path(__file__).resolve().parent.parent / "tests" / "programs" / "comp"


def _rot(p, angle, origin):
    c, s = math.cos(angle), math.sin(angle)
    return (origin[0] + c * p[0] - s * p[1], origin[1] + s * p[0] + c * p[1])


def _fmt(v):
    text = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


class Writer:
    def __init__(self, angle, origin):
        self.angle, self.origin, self.lines = angle, origin, []

    def at(self, p):
        return _rot(p, self.angle, self.origin)

    def line(self, p, head="G1"):
        x, y = self.at(p)
        self.lines.append(f"{head} X{_fmt(x)} Y{_fmt(y)}")

    def arc(self, start, end, centre, cw, head=""):
        s, e, c = self.at(start), self.at(end), self.at(centre)
        code = "G2" if cw else "G3"
        self.lines.append(f"{head}{code} X{_fmt(e[0])} Y{_fmt(e[1])} I{_fmt(c[0] - s[0])} "
                          f"J{_fmt(c[1] - s[1])}")


def rounded_rectangle(w, h, rc, reverse):
    """A rectangle w x h with corners of radius rc, its lower-left corner at (0, 0):
    elements ``("line", end)`` / ``("arc", end, centre, cw)`` from its first point."""
    pts = [("line", (w - rc, 0)), ("arc", (w, rc), (w - rc, rc), False),
           ("line", (w, h - rc)), ("arc", (w - rc, h), (w - rc, h - rc), False),
           ("line", (rc, h)), ("arc", (0, h - rc), (rc, h - rc), False),
           ("line", (0, rc)), ("arc", (rc, 0), (rc, rc), False)]
    return _reversed((rc, 0), pts) if reverse else ((rc, 0), pts)


def slot(length, radius, reverse):
    pts = [("line", (length, 0)), ("arc", (length, 2 * radius), (length, radius), False),
           ("line", (0, 2 * radius)), ("arc", (0, 0), (0, radius), False)]
    return _reversed((0, 0), pts) if reverse else ((0, 0), pts)


def kinked(size, kink, reverse):
    """Lines and arcs meeting at kinks: a square whose edges are arcs bulging inwards (their
    ends at ``kink`` degrees to the edge) joined by chamfer lines at the corners (so the
    kinks are 45 - kink and 45 + kink degrees, concave and convex)."""
    k = math.radians(kink)
    pts = []
    corners = [(0, 0), (size, 0), (size, size), (0, size)]
    start = None
    for i, corner in enumerate(corners):
        nxt = corners[(i + 1) % 4]
        d = ((nxt[0] - corner[0]) / size, (nxt[1] - corner[1]) / size)
        a = (corner[0] + d[0] * size * 0.2, corner[1] + d[1] * size * 0.2)
        b = (corner[0] + d[0] * size * 0.8, corner[1] + d[1] * size * 0.8)
        if start is None:
            start = a
        else:
            pts.append(("line", a))
        # An arc from a to b bulging inwards (its centre to the right of d, outside the
        # square run counter-clockwise), its tangent at a turned by k to the left of d.
        half = size * 0.3
        rad = half / math.sin(k)
        centre = ((a[0] + b[0]) / 2 - d[1] * -rad * math.cos(k),
                  (a[1] + b[1]) / 2 + d[0] * -rad * math.cos(k))
        pts.append(("arc", b, centre, True))
    pts.append(("line", start))
    # Begun half way along a chamfer line (a lead-in meets a line, away from the corners).
    last = pts[-2][1]
    middle = ((last[0] + start[0]) / 2, (last[1] + start[1]) / 2)
    pts = [("line", start)] + pts[:-1] + [("line", middle)]
    start = middle
    return _reversed(start, pts) if reverse else (start, pts)


def _reversed(start, pts):
    """The same profile run the other way, begun with a line (a lead-in meets a line)."""
    points = [start] + [p[1] for p in pts]
    out = []
    for i in range(len(pts) - 1, -1, -1):
        p = pts[i]
        end = points[i]
        if p[0] == "line":
            out.append(("line", end))
        else:
            out.append(("arc", end, p[2], not p[3]))
    while out[0][0] != "line":
        start, out = out[0][1], out[1:] + out[:1]
    return start, out


def program(name, title, shape, side, units, diameter, angle, origin):
    """The program (text) of ``shape`` (``(first point, elements)``) rotated by ``angle`` about
    the origin and moved to ``origin``, cut on ``side`` with a cutter of ``diameter``."""
    first, pts = shape
    w = Writer(angle, origin)
    scale = 25.4 if units == "G20" else 1.0
    title = title.replace("(", "[").replace(")", "]")
    w.lines += [f"({name}: {title})", "(generated by kontur/profiles.py)",
                f"{units} G90 G17 F{600 / scale:g}"]
    t0 = pts[0][1]
    d = (t0[0] - first[0], t0[1] - first[1])
    norm = math.hypot(*d)
    # Entry from off the part, perpendicular to the first element, on the cutter's side.
    sign = 1 if side == "G41" else -1
    if pts[0][0] == "line":
        n = (-d[1] / norm * sign, d[0] / norm * sign)
    else:
        n = (0, -sign)
    lead = diameter + 3 / scale              # longer than the radius, as LinuxCNC wants
    off = (first[0] + n[0] * lead, first[1] + n[1] * lead)
    w.line(off, "G0")
    x, y = w.at(first)
    w.lines.append(f"{side}.1 D{_fmt(diameter)} G1 X{_fmt(x)} Y{_fmt(y)}")
    at = first
    for p in pts:
        if p[0] == "line":
            w.line(p[1])
        else:
            w.arc(at, p[1], p[2], p[3])
        at = p[1]
    x, y = w.at(off)
    w.lines.append(f"G40 G1 X{_fmt(x)} Y{_fmt(y)}")
    w.lines.append("M2")
    return "\n".join(w.lines) + "\n"


def random_programs(count, seed=26):
    """``count`` random profiles (rounded rectangles, slots, kinked squares in turn; sides,
    directions, rotations, places, sizes and diameters at random, in mm): ``(name, text)``."""
    pick = random.Random(seed)
    for n in range(count):
        kind = ("rrect", "slot", "kink")[n % 3]
        side = pick.choice(("G41", "G42"))
        reverse = pick.random() < 0.5
        angle = pick.uniform(-math.pi, math.pi)
        origin = (pick.uniform(-20, 20), pick.uniform(-20, 20))
        if kind == "rrect":
            w, h, rc = pick.uniform(20, 40), pick.uniform(15, 30), pick.uniform(3, 7)
            shape, diameter = rounded_rectangle(w, h, rc, reverse), pick.uniform(1, 1.8 * rc)
        elif kind == "slot":
            rc = pick.uniform(3, 8)
            shape, diameter = slot(pick.uniform(15, 35), rc, reverse), pick.uniform(1, 1.8 * rc)
        else:
            shape = kinked(pick.uniform(20, 35), pick.uniform(10, 35), reverse)
            diameter = pick.uniform(1, 6)
        name = f"random{n}_{kind}"
        yield name, program(name, kind, shape, side, "G21", round(diameter, 3), angle, origin)


#: The random profiles (:func:`random_programs`, seed 26) kept in the corpus: those whose path
#: was farther than 1.5 steps from rs274's before the cutter radius was taken exactly (1.84,
#: 1.74 and 1.53 steps; issue 26).
RANDOM_IN_CORPUS = ("random8_kink", "random19_slot", "random20_kink")


def main():
    mm, inch = "G21", "G20"
    out = []
    for name, text in random_programs(45):
        if name in RANDOM_IN_CORPUS:
            (CORPUS / f"{name}.ngc").write_text(text)
            out.append(name)
    specs = [
        ("rrect_out_g42", "rounded rectangle 40 x 25 R6, outside, G42 (ccw)",
         rounded_rectangle(40, 25, 6, False), "G42", mm, 6, 0.3, (10.1234, 5.4321)),
        ("rrect_in_g41", "rounded rectangle 40 x 25 R6, inside, G41 (ccw)",
         rounded_rectangle(40, 25, 6, False), "G41", mm, 8, 0.3, (10.1234, 5.4321)),
        ("rrect_out_g41", "rounded rectangle, outside, G41 (cw)",
         rounded_rectangle(32, 21, 4.5, True), "G41", mm, 6.35, -0.7, (3.3, -7.7)),
        ("rrect_in_g42", "rounded rectangle, inside, G42 (cw)",
         rounded_rectangle(32, 21, 4.5, True), "G42", mm, 5, 1.1, (-12.34, 8.76)),
        ("rrect_square", "rounded rectangle, axis-parallel, R3",
         rounded_rectangle(30, 30, 3, False), "G42", mm, 4, 0.0, (0.1, 0.2)),
        ("rrect_inch", "rounded rectangle in inches, outside",
         rounded_rectangle(1.5, 1.0, 0.25, False), "G42", inch, 0.25, 0.2, (0.3, 0.4)),
        ("rrect_inch_in", "rounded rectangle in inches, inside",
         rounded_rectangle(1.5, 1.0, 0.25, True), "G42", inch, 0.375, -0.4, (-0.3, 0.4)),
        ("slot_out", "slot 30 x R5, outside, G42", slot(30, 5, False), "G42", mm, 6, 0.45,
         (2.2, 3.3)),
        ("slot_in", "slot 30 x R7, inside, G41", slot(30, 7, False), "G41", mm, 10, 0.45,
         (2.2, 3.3)),
        ("slot_out_cw", "slot, outside, G41 (cw)", slot(25, 6, True), "G41", mm, 8, -1.2,
         (5, -5)),
        ("slot_in_cw", "slot, inside, G42 (cw)", slot(25, 6, True), "G42", mm, 6, 2.0, (5, -5)),
        ("slot_inch", "slot in inches, outside", slot(1.2, 0.2, False), "G42", inch, 0.125,
         0.77, (0.1, 0.1)),
        ("kink20_out", "inward arcs meeting chamfer lines at kinks, outside", kinked(30, 20, False),
         "G42", mm, 6, 0.1, (1.1, 2.2)),
        ("kink20_in", "inward arcs meeting chamfer lines at kinks, inside", kinked(30, 20, False),
         "G41", mm, 4, 0.1, (1.1, 2.2)),
        ("kink20_out_cw", "inward arcs and chamfers, outside, cw", kinked(30, 20, True), "G41", mm, 5,
         -0.5, (-3, 4)),
        ("kink20_in_cw", "inward arcs and chamfers, inside, cw", kinked(30, 20, True), "G42", mm, 3,
         -0.5, (-3, 4)),
        ("kink35_out", "inward arcs (35 degrees at their ends) and chamfers, outside", kinked(25, 35, False), "G42", mm, 6, 0.9,
         (0, 0)),
        ("kink35_inch", "inward arcs (35 degrees) and chamfers, inches, inside", kinked(1.0, 35, False), "G41", inch,
         0.125, 0.9, (0.5, 0.5)),
        ("slot_inch_in", "slot in inches, inside, G41", slot(1.0, 0.3, False), "G41", inch,
         0.25, -0.3, (0.2, -0.1)),
        ("rrect_inch_g41", "rounded rectangle in inches, outside, G41 [cw]",
         rounded_rectangle(1.2, 0.8, 0.2, True), "G41", inch, 0.25, 0.6, (-0.2, 0.3)),
    ]
    for spec in specs:
        (CORPUS / f"{spec[0]}.ngc").write_text(program(*spec))
        out.append(spec[0])
    return out


if __name__ == "__main__":
    print(" ".join(main()))
