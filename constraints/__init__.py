"""Boards and the flows that build for them: pin maps and platforms (``icebreaker.py``), the
synthesis and place-and-route runs (``flow.py``), the area and speed tables (``bench.py``) and
the demo bitstream (``build.py``).

Pin maps live here and only here; ``hdl/top.py`` requests resources by name. Which boards
there are is said once, in :data:`sim.registry.BOARDS`.
"""
