"""The program: the ``kontur`` command and everything it composes.

:mod:`kontur.registry` is the composition root (the kinds, variants and boards, each named
once); above it stand the commands: ``trace`` (:mod:`kontur.trace`), ``run`` and ``send`` (the
host of a machine controller: :mod:`kontur.gcode`, :mod:`kontur.machine`,
:mod:`kontur.planner`, :mod:`kontur.compensation`, :mod:`kontur.machining`,
:mod:`kontur.send`, :mod:`kontur.plot`), ``demo``, ``bench`` (:mod:`kontur.bench`,
:mod:`kontur.accuracy`), ``build`` (:mod:`kontur.build`) and the waveform regression
(:mod:`kontur.waves`). It stands on every floor below (``hdl``, ``sim``, ``constraints``);
nothing below imports it (``tests/test_layers.py``).

Installed, the distribution claims this one name: ``hdl``, ``sim`` and ``constraints`` go in as
``kontur.hdl``, ``kontur.sim`` and ``kontur.constraints`` (``pyproject.toml`` maps them). In a
checkout they stay at the project's top, beside this package (the design card's layout), and
the lines below let the same names find them there.
"""

from pathlib import Path

_CHECKOUT = Path(__file__).resolve().parent.parent
if not (Path(__file__).parent / "hdl").is_dir() and (_CHECKOUT / "hdl" / "__init__.py").is_file():
    __path__.append(str(_CHECKOUT))
