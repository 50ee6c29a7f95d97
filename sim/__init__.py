"""kontur's simulation floor: golden models (:mod:`sim.models`, pure Python), the stimulus
every simulator plays (:mod:`sim.stimulus`), the runners (Amaranth's simulator, Icarus,
Verilator: :mod:`sim.runners`, :mod:`sim.fastrun`), the cocotb parts (:mod:`sim.testbench`),
the child processes' groups (:mod:`sim.processes`) and the proofs' runner (:mod:`sim.formal`).

It stands on ``hdl`` alone; the boards (``constraints``) and the program (``kontur``: the
registry, the command line, the host) stand on it, and nothing here imports them
(``tests/test_layers.py``)."""
