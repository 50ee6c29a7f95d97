"""kontur's simulation side: golden models, the stimulus every simulator runs, the runners
(Amaranth's simulator, Icarus, Verilator), waveforms, and the registry of kinds, variants and
boards. Host tools (the command line) are in :mod:`sim.host`."""
