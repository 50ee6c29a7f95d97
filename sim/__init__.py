"""kontur's simulation floor: golden models (:mod:`kontur.sim.models`, pure Python), the stimulus
every simulator plays (:mod:`kontur.sim.stimulus`), the runners (Amaranth's simulator, Icarus,
Verilator: :mod:`kontur.sim.runners`, :mod:`kontur.sim.fastrun`), the cocotb parts (:mod:`kontur.sim.testbench`),
the child processes' groups (:mod:`kontur.sim.processes`) and the proofs' runner (:mod:`kontur.sim.formal`).

It stands on ``hdl`` alone; the boards (``constraints``) and the program (``kontur``: the
registry, the command line, the host) stand on it, and nothing here imports them
(``tests/test_layers.py``)."""
