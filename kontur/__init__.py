"""The program: the ``kontur`` command and everything it composes.

:mod:`kontur.registry` is the composition root (the kinds, variants and boards, each named
once); above it stand the commands: ``trace`` (:mod:`kontur.trace`), ``run`` and ``send`` (the
host of a machine controller: :mod:`kontur.gcode`, :mod:`kontur.machine`,
:mod:`kontur.planner`, :mod:`kontur.compensation`, :mod:`kontur.machining`,
:mod:`kontur.send`, :mod:`kontur.plot`), ``demo``, ``bench`` (:mod:`kontur.bench`,
:mod:`kontur.accuracy`), ``build`` (:mod:`kontur.build`) and the waveform regression
(:mod:`kontur.waves`). It stands on every floor below (``hdl``, ``sim``, ``constraints``);
nothing below imports it (``tests/test_layers.py``).
"""
