"""Formal properties, one module per design module: harnesses that wrap a design with
``Assume``/``Assert`` (``amaranth.hdl``) and free inputs (``AnySeq``, ``AnyConst``).

Each harness is an :class:`~amaranth.hdl.Elaboratable` with no ports of its own: every input of
the design it wraps is free unless an ``Assume`` says otherwise, and every claim is an
``Assert`` on the design's ports and on its patent-named elements (``adder1.q``,
``counter7.q``, ...). ``sim/formal.py`` lists the proofs (harness, parameters, induction depth)
and runs them with SymbiYosys; ``docs/formal.md`` states each property, the widths it is
proven at, its proof time, and the argument where a small width stands for every width.

Modules: :mod:`.elements` (the element library), :mod:`.linear` (SU 1571551),
:mod:`.circular` (SU 1665343). The engines' contracts are not proven here (see
``docs/formal.md``, "Not proven").
"""
