"""Boards and the flows that build for them: pin maps and platforms (``icebreaker.py``,
``ulx3s.py``, ``shift_in.py``) and the synthesis and place-and-route runs (``flow.py``).

Pin maps live here and only here; ``hdl/top.py`` requests resources by name. Which boards
there are is said once, in :data:`kontur.registry.BOARDS`; the benches and ``kontur build``
that read it are the program's (:mod:`kontur.bench`, :mod:`kontur.build`).
"""
