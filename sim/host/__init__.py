"""The host side: the ``kontur`` command and what it runs (trace, demo).

It stands on the simulation layer (``sim``: models, runners, the registry) and on the boards
and synthesis flows (``constraints``); nothing there imports it.
"""
