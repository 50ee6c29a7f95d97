# amaranth: UnusedElaboratable=no
"""``kontur build --machine FILE``: the controller built with a machine file's link and queue
(the tools replaced by a stand-in that keeps the design: nothing is placed or routed here), and
machine files the controller cannot take refused before anything is built."""

import os
import subprocess
from pathlib import Path

import pytest

import kontur.build
from kontur import registry
from kontur.cli import main

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def built(monkeypatch):
    """The designs handed to the tools, instead of placing and routing them."""
    designs = []

    def place_and_route(platform, top, build_dir, *, seed):
        designs.append(top)
        return {"bitstream": str(Path(build_dir) / "top.bin"), "log": "log", "utilisation": {},
                "fmax": {}, "seed": seed, "seconds": 0.0}
    monkeypatch.setattr(kontur.build, "place_and_route", place_and_route)
    return designs


def _machine(tmp_path, text):
    path = tmp_path / "machine.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("board", ["icebreaker", "ulx3s"])
def test_machine_file_sets_the_controllers_link_and_queue(board, built, tmp_path, capsys):
    path = _machine(tmp_path, "baud = 57600\nqueue_frames = 12\n")
    assert main(["build", "--board", board, "--machine", path,
                 "--build-dir", str(tmp_path / "b")]) == 0
    assert main(["build", "--board", board, "--build-dir", str(tmp_path / "d")]) == 0
    custom, default = (top.controller for top in built)
    assert custom.queue_frames == 12 and default.queue_frames == 32
    clock = registry.board(board).clock_hz                 # the bit time, clocks a bit
    assert round(clock / 57600) == custom._divisor != default._divisor == round(clock / 115200)
    out = capsys.readouterr().out
    assert f"machine    {path}: 57600 baud, queue of 12 frames (kontur send --machine {path})\n" \
        in out


BAD = {"queue_frames = 1\n": "queue_frames must be an integer from 2 to 255",
       "queue_frames = 256\n": "queue_frames must be an integer from 2 to 255",
       "baud = 100000000\n": "baud 1e+08 cannot be made from the 6 MHz clock",
       "bauds = 9600\n": "unknown key 'bauds'",
       "queue_frames = 2.5\n": "queue_frames must be an integer"}


@pytest.mark.parametrize("text", BAD)
def test_bad_machine_file_refused_before_building(text, built, tmp_path, capsys):
    path = _machine(tmp_path, text)
    assert main(["build", "--machine", path]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and BAD[text] in err, err
    assert built == []                                      # nothing went to the tools
    assert main(["build", "--machine", str(tmp_path / "none.toml")]) == 2
    assert "cannot read the machine file" in capsys.readouterr().err
    assert main(["build", "--top", "player", "--machine", path]) == 2
    assert built == []


def test_make_bitstream_passes_the_machine_file():
    # make -n prints the recipe: the machine file reaches kontur build.
    # (Under `make test` the outer make's level and flags would add "Entering directory" lines.)
    env = {k: v for k, v in os.environ.items() if k not in ("MAKELEVEL", "MAKEFLAGS", "MFLAGS")}
    run = subprocess.run(["make", "-n", "--no-print-directory", "-o", "setup", "bitstream",
                          "BOARD=ulx3s", "MACHINE=m.toml"], cwd=ROOT, capture_output=True,
                         text=True, timeout=30, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1].endswith(
        "kontur build --board ulx3s --top controller --machine m.toml")
