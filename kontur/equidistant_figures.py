"""Figures of the equidistant interpolator, measured now: ``python -m
kontur.equidistant_figures accuracy|formats|timing|fpga`` (docs/equidistant.md quotes them).

* ``accuracy``: every test program (``tests/programs``), both sides, both corner treatments,
  radii 0 to 8, both detections: the farthest visited point from the exact equidistant, the
  distances from the profile, the corners; then random polygons.
* ``formats``: the effect of the fractional bits on a long line and on the test programs.
* ``timing``: clocks, idle clocks and the first step of each test program on the cycle model.
* ``fpga``: area (Yosys, nextpnr's packer) of the engine at widths 8 to 16, and speed (placed and
  routed on the iCEBreaker) at width 8, the widest that fits the UP5K, both arc cores.
"""

import math
import random
import sys
from pathlib import Path

from kontur.sim.models.equidistant import (DETECTIONS, TREATMENTS, Formats, ProfileError, check_trace,
                                  prepare, profile_from_moves)
from kontur.gcode import read

__all__ = ["main"]

PROGRAMS = Path(__file__).resolve().parent.parent / "tests" / "programs"
RADII = (0, 1, 2, 3, 5, 8)


def _programs():
    for path in sorted(PROGRAMS.glob("*.ngc")):
        text = path.read_text()
        for swap in (False, True):
            if swap:
                text = text.replace("G41", "@").replace("G42", "G41").replace("@", "G42")
            yield path.stem, profile_from_moves(read(text).moves)


def _polygon(rng):
    """A random star-shaped polygon about the origin, counter-clockwise."""
    count = rng.randint(3, 8)
    angles = sorted(rng.uniform(0, 2 * math.pi) for _ in range(count))
    points = [(round(rng.uniform(30, 120) * math.cos(a)), round(rng.uniform(30, 120)
                                                                 * math.sin(a)))
              for a in angles]
    lines = [f"G0 X{points[0][0]} Y{points[0][1]}",
             f"{rng.choice(['G41', 'G42'])} G1 X{points[1][0]} Y{points[1][1]}"]
    lines += [f"G1 X{x} Y{y}" for x, y in points[2:] + points[:1]]
    return profile_from_moves(read("\n".join(lines)).moves)


def _measure(shape, r, treatment, detection, formats=Formats()):
    try:
        prepared = prepare(shape, r, treatment=treatment, detection=detection, formats=formats,
                           verify=False)
    except ProfileError:
        return None
    report = check_trace(prepared)
    if report.near < r - 1 or report.path > 2:        # the equidistant cuts the profile
        return None
    return report


def accuracy(out):
    out.write("Test programs (tests/programs, both sides, radii 0-8): largest distance of a "
              "visited point\nfrom the exact equidistant, distances from the profile less r "
              "(arc treatment), corners\n\n")
    out.write(f"{'treatment':10} {'detection':9} {'runs':>5} {'path':>6} {'near':>7} "
              f"{'far':>6} {'corner':>7}\n")
    for treatment in TREATMENTS:
        for detection in DETECTIONS:
            runs, path, near, far, corner = 0, 0, 0, 0, 0
            for _, shape in _programs():
                for r in RADII:
                    report = _measure(shape, r, treatment, detection)
                    if report is None:
                        continue
                    runs += 1
                    path = max(path, report.path)
                    near = min(near, report.near - r)
                    far = max(far, report.far - r)
                    corner = max([corner] + [d for _, d in report.corners])
            out.write(f"{treatment:10} {detection:9} {runs:5} {float(path):6.3f} "
                      f"{float(near):7.3f} {float(far) if treatment == 'arc' else 0:6.3f} "
                      f"{float(corner):7.3f}\n")
    rng = random.Random(1963)
    shapes = [_polygon(rng) for _ in range(300)]
    out.write("\nRandom star polygons (300, seed 1963; radii 0-8 at random; those whose "
              "equidistant cuts the profile left out)\n\n")
    out.write(f"{'detection':9} {'runs':>5} {'path':>6} {'corner':>7} {'corners > 1':>12}\n")
    for detection in DETECTIONS:
        runs, path, corner, beyond = 0, 0, 0, 0
        pick = random.Random(7)
        for shape in shapes:
            report = _measure(shape, pick.choice(RADII), pick.choice(TREATMENTS), detection)
            if report is None:
                continue
            runs += 1
            path = max(path, report.path)
            ends = [d for _, d in report.corners]
            corner = max([corner] + ends)
            beyond += sum(1 for d in ends if d > 1)
        out.write(f"{detection:9} {runs:5} {float(path):6.3f} {float(corner):7.3f} "
                  f"{beyond:12}\n")
    return 0


def formats(out):
    line = profile_from_moves(read("G41 G1 X30001 Y10000\n").moves)
    out.write("A line of 31623 steps (slope 1/3), r = 0, width 15: distance from the exact line "
              "by fractional bits\n\n")
    for fraction in (8, 11, 13, 15, 17, 19, 23):
        prepared = prepare(line, 0, formats=Formats(15, fraction), verify=False)
        out.write(f"  F = {fraction:2}: {float(check_trace(prepared).path):.4f}\n")
    out.write("\nThe test programs (both sides, radii 0-8), width 16: largest distance from the "
              "equidistant\n\n")
    for fraction in (6, 8, 12, 16, 20):
        path = 0
        for _, shape in _programs():
            for r in RADII:
                report = _measure(shape, r, "arc", "normal", Formats(16, fraction))
                if report is not None:
                    path = max(path, report.path)
        out.write(f"  F = {fraction:2}: {float(path):.4f}\n")
    return 0


def timing(out):
    from kontur.sim.models.circular import FaithfulArcCoreModel, FastArcCoreModel
    from kontur.sim.models.equidistant import EquidistantEngineModel
    from kontur.sim.stimulus import Job, run_model
    out.write("Cycle model, width 16, a step permitted every clock, r = 3, arc corners: clocks "
              "of the whole\nprogram, steps, idle clocks between the first and the last step, "
              "clock of the first step\n\n")
    out.write(f"{'program':10} {'core':9} {'clocks':>7} {'steps':>6} {'idle':>5} "
              f"{'first':>6}\n")
    for name in ("square", "triangle", "polygon", "rounded", "pie", "lens", "circle"):
        shape = profile_from_moves(read((PROGRAMS / f"{name}.ngc").read_text()).moves)
        prepared = prepare(shape, 1 if name == "triangle" else 3, treatment="arc")
        for core, make in (("fast", FastArcCoreModel), ("faithful", FaithfulArcCoreModel)):
            record = run_model(EquidistantEngineModel(make(width=18)),
                               Job(frames=list(prepared.frames), max_cycles=1_000_000))
            moves = [e["cycle"] for e in record if not e["rst"] and e["step"]]
            idle = moves[-1] - moves[0] + 1 - len(moves)
            out.write(f"{name:10} {core:9} {len(record):7} {len(moves):6} {idle:5} "
                      f"{moves[0]:6}\n")
    return 0


def fpga(out):
    from kontur import bench
    from kontur import registry

    def design(name, width):
        return ("profile engine", width, name,
                lambda: registry.make_engine("profile", name, width=width))
    bench.area(out, designs=[design(name, width) for width in (8, 10, 12, 16)
                             for name in registry.variants("profile")])
    out.write("\nSpeed on the iCEBreaker (iCE40UP5K-SG48): the engine in ShiftInTop, width 8, "
              "placed and routed\n(nextpnr fails the build below the board's 12 MHz; the "
              "routed figure is read from its log)\n\n")
    from kontur.constraints.flow import SEED, DoesNotFit, measure_speed
    for name in registry.variants("profile"):
        build_dir = bench.BUILD_ROOT / "speed" / f"profile_engine_w8_{name}"
        try:
            result = measure_speed(registry.make_engine("profile", name, width=8), build_dir)
        except DoesNotFit as error:
            # Refused before placement: the packed design is larger than the device.
            out.write(f"  {name:9} does not fit: LC {error.used} of {error.available}\n")
            continue
        run = result["runs"][SEED]
        fmax, lc = run["fmax"], run["logic"]
        (mhz, verdict, target), = fmax.values()
        out.write(f"  {name:9} {mhz:6.2f} MHz ({verdict or '-'} at {target:g} MHz), "
                  f"LC {lc[0]} of {lc[1]}\n")
    return 0


def main(argv=None, out=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    out = sys.stdout if out is None else out
    jobs = {"accuracy": accuracy, "formats": formats, "timing": timing, "fpga": fpga}
    if len(argv) != 1 or argv[0] not in jobs:
        sys.stderr.write(f"usage: python -m kontur.equidistant_figures "
                         f"{'|'.join(jobs)}\n")
        return 2
    return jobs[argv[0]](out)


if __name__ == "__main__":
    sys.exit(main())
