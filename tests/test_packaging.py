"""Installed, the project claims only its own name (issue 24): the wheel holds ``kontur`` and its
metadata, nothing at the top of site-packages named ``hdl``, ``sim`` or ``constraints``, and the
installed copy runs from a bare directory, away from the checkout, making the checkout's steps."""

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(command, **kwargs):
    result = subprocess.run(command, capture_output=True, text=True, **kwargs)
    assert result.returncode == 0, f"{' '.join(map(str, command))}\n{result.stdout}\n{result.stderr}"
    return result


def test_the_wheel_claims_only_kontur_and_runs_installed(tmp_path):
    # A copy of what the build reads, so that building leaves no build/ or egg-info behind.
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    for name in ("hdl", "sim", "constraints", "kontur"):
        shutil.copytree(ROOT / name, source / name,
                        ignore=shutil.ignore_patterns("__pycache__"))
    env = {key: value for key, value in os.environ.items() if key != "PYTHONWARNINGS"}
    run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
         "--wheel-dir", tmp_path / "dist", source], env=env)
    (wheel,) = (tmp_path / "dist").glob("kontur-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    version = wheel.name.split("-")[1]
    assert {name.split("/")[0] for name in names} == {"kontur", f"kontur-{version}.dist-info"}
    for wanted in ("kontur/hdl/top.py", "kontur/hdl/motion/controller.py",
                   "kontur/sim/models/equidistant/__init__.py", "kontur/sim/fastrun.cpp",
                   "kontur/sim/testbench/trace.py", "kontur/constraints/flow.py",
                   "kontur/programs/bracket.ngc"):
        assert wanted in names, wanted

    target = tmp_path / "site"
    run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", target,
         wheel], env=env)
    bare = tmp_path / "bare"
    bare.mkdir()
    env["PYTHONPATH"] = str(target)
    where = run([sys.executable, "-c",
                 "import importlib.util, kontur.hdl.top, kontur.cli\n"
                 "print(kontur.hdl.top.__file__)\n"
                 "print([n for n in ('hdl', 'sim', 'constraints') if importlib.util.find_spec(n)])"],
                cwd=bare, env=env).stdout.split("\n")
    assert Path(where[0]).is_relative_to(target), where
    assert where[1] == "[]", where

    program = target / "kontur" / "programs" / "bracket.ngc"
    run([sys.executable, "-m", "kontur.cli", "run", program, "--engine", "model",
         "--out", bare / "installed"], cwd=bare, env=env)
    run([sys.executable, "-m", "kontur.cli", "run", ROOT / "kontur" / "programs" / "bracket.ngc",
         "--engine", "model", "--out", tmp_path / "checkout"], cwd=ROOT)
    installed = (bare / "installed" / "steps.txt").read_text()
    assert installed == (tmp_path / "checkout" / "steps.txt").read_text()
    assert len(installed.splitlines()) > 1000
    summary = json.loads((bare / "installed" / "summary.json").read_text())
    assert summary["engine"] == "model", summary
