"""kontur as a Grbl 1.1 device (``kontur serve``): any G-code sender drives the virtual machine.

:mod:`.protocol` is what Grbl says (codes, reports, the map from kontur's refusals to Grbl's
errors), :mod:`.settings` the ``$`` settings on the machine file, :mod:`.motion` the golden
model's steps played against a clock, :mod:`.session` the device (bytes in, lines out) and
:mod:`.server` the pseudo-terminal and TCP loop. docs/grbl.md is the user's side.
"""
