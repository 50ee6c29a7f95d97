# amaranth: UnusedElaboratable=no
"""The machine's configuration (:class:`kontur.machine.Machine`) takes exactly what the
gateware takes: every value the controller's constructor, the UART's bit time or the feed
generator's fields refuse is refused when the machine is made, naming the key."""

import pytest

from kontur.hdl.motion.uart import divisor_for
from kontur import registry
from kontur.machine import Machine, MachineError

CLOCK = registry.board("icebreaker").clock_hz


def _gateware_takes(**values):
    """Whether the icebreaker's controller can be made with these values (its constructor
    and the UART's bit time), and the acceleration fits CONFIG's Q0.40 field (computed here
    from the definition: mm/s^2 times steps/mm over clock^2, 40 fraction bits, 32 bits)."""
    machine = Machine.__new__(Machine)
    defaults = {f: getattr(Machine, f) for f in ("steps_per_mm", "max_feed", "accel",
                                                 "junction_deviation", "arc_tolerance", "baud",
                                                 "dir_setup_us", "step_width_us", "queue_frames",
                                                 "cutter_radius")}
    defaults.update(values, clock_hz=CLOCK)
    for key, value in defaults.items():
        object.__setattr__(machine, key, value)
    q40 = round(machine.accel * machine.steps_per_mm / CLOCK ** 2 * 2 ** 40)
    if not 1 <= q40 < 2 ** 32:
        return False
    try:
        divisor_for(CLOCK, machine.baud)
        registry.make_controller("icebreaker", machine)
    except (TypeError, ValueError):
        return False
    return True


@pytest.mark.parametrize("key, values", [
    ("queue_frames", [1, 2, 3, 32, 255, 256, 1000]),
    ("baud", [9600, 115200, 1_000_000, CLOCK // 4, CLOCK // 3, CLOCK // 2, 10 ** 8]),
    ("accel", [1e-9, 0.01, 0.5, 500, 1e9, 1e12]),
])
def test_machine_takes_what_the_gateware_takes(key, values):
    for value in values:
        takes = _gateware_takes(**{key: value})
        if takes:
            assert getattr(Machine(clock_hz=CLOCK, **{key: value}).check(), key) == value
        else:
            with pytest.raises(MachineError, match=key):
                Machine(clock_hz=CLOCK, **{key: value}).check()


def test_both_sides_seen():
    """The cases above include values on both sides of every limit (else they prove nothing)."""
    assert not _gateware_takes(queue_frames=1) and _gateware_takes(queue_frames=2)
    assert _gateware_takes(queue_frames=255) and not _gateware_takes(queue_frames=256)
    assert not _gateware_takes(baud=10 ** 8) and _gateware_takes(baud=115200)
    assert not _gateware_takes(accel=1e-9) and _gateware_takes(accel=500)


def test_whole_float_integers_become_integers():
    """TOML's ``queue_frames = 2.0`` is the integer 2 (the gateware's constructors take ints)."""
    machine = Machine(clock_hz=CLOCK, queue_frames=2.0, baud=115200.0)
    assert type(machine.queue_frames) is int and type(machine.baud) is int


def test_binary_machine_file(tmp_path):
    path = tmp_path / "m.toml"
    path.write_bytes(b"\xff\xfe\x00 binary")
    with pytest.raises(MachineError, match="m.toml"):
        Machine.from_toml(path, clock_hz=CLOCK)


@pytest.mark.parametrize("value, taken", [
    ([0, 300], (0.0, 300.0)), ((-12.5, 12.5), (-12.5, 12.5)), (None, None),
    ([300, 0], False), ([5, 5], False), ([0], False), ("0 300", False), ([0, float("inf")], False),
    ([True, 3], False),
])
def test_travel(value, taken):
    if taken is False:
        with pytest.raises(MachineError, match=r"^travel_y must be \[min, max\] in mm"):
            Machine(travel_y=value)
    else:
        assert Machine(travel_y=value).travel_y == taken
