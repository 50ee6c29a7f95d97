"""Waveform regression: reduce a VCD dump to a canonical clock-by-clock trace.

Raw dumps are never compared: Amaranth stamps a wall-clock date in the header, the simulators
name scopes differently (Amaranth ``bench.top.engine``, Icarus ``engine``, Verilator
``$rootio`` and ``engine``). :func:`sample_vcd` finds each requested signal by the end of its
hierarchical name (the shallowest match wins) and returns the value every signal had during
each clock, i.e. just before each rising edge of ``clk``. Golden traces live in
``tests/golden/*.trace``; :func:`check_trace` compares with them and rewrites them only on
purpose (``UPDATE_GOLDEN=1``).
"""

import io
import os
import re
from pathlib import Path

from vcd.reader import TokenKind, tokenize

__all__ = ["sample_vcd", "format_trace", "check_trace"]


def _find(paths, suffix):
    wanted = tuple(suffix.split("."))
    matches = [p for p in paths if p[-len(wanted):] == wanted]
    if not matches:
        raise KeyError(f"no signal ending in {suffix!r} in the dump")
    return min(matches, key=len)


def sample_vcd(path, signals, *, clock="clk"):
    """Return one dict per clock of the dump at ``path``: ``{name: value}`` for ``signals``.

    ``signals`` maps result names to hierarchical name suffixes (``"step"``,
    ``"core.adder3.q"``). Values are unsigned integers; an undefined (``x``) value is ``None``.
    """
    raw = Path(path).read_bytes()
    # Verilator writes names that start with "$" (its "$rootio" scope, Yosys's internal
    # wires), which pyvcd 0.4 does not accept: drop that "$".
    raw = re.sub(rb"(\$scope\s+\w+\s+)\$", rb"\1", raw)
    raw = re.sub(rb"(\$var\s+\w+\s+\d+\s+\S+\s+)\$", rb"\1", raw)
    tokens = list(tokenize(io.BytesIO(raw)))
    scope = []
    by_path = {}                                     # hierarchical path -> id code
    for token in tokens:
        if token.kind is TokenKind.SCOPE:
            scope.append(token.data.ident)
        elif token.kind is TokenKind.UPSCOPE:
            scope.pop()
        elif token.kind is TokenKind.VAR:
            by_path.setdefault(tuple(scope) + (token.data.reference,), token.data.id_code)
    ids = {name: by_path[_find(list(by_path), suffix)] for name, suffix in signals.items()}
    clock_id = by_path[_find(list(by_path), clock)]

    values = {}
    pending = {}                                     # changes at the current timestamp
    rows = []

    def close_timestamp():
        if pending.get(clock_id) == 1 and values.get(clock_id) == 0:
            rows.append({name: values.get(code) for name, code in ids.items()})
        values.update(pending)
        pending.clear()

    for token in tokens:
        if token.kind is TokenKind.CHANGE_TIME:
            close_timestamp()
        elif token.kind is TokenKind.CHANGE_SCALAR:
            pending[token.data.id_code] = {"0": 0, "1": 1}.get(token.data.value)
        elif token.kind is TokenKind.CHANGE_VECTOR:
            value = token.data.value
            pending[token.data.id_code] = value if isinstance(value, int) else None
    close_timestamp()
    return rows


def format_trace(columns, rows):
    """Text of a trace: a header line of ``columns``, then one line per row."""
    return "".join(" ".join(str(v) for v in row) + "\n" for row in [columns, *rows])


def check_trace(path, columns, rows):
    """Compare ``rows`` with the golden trace at ``path`` (comment lines ``#`` ignored).

    ``UPDATE_GOLDEN=1`` rewrites the file instead (keeping its comment lines); use it only on
    purpose, after checking the waveform.
    """
    path = Path(path)
    text = format_trace(columns, rows)
    if os.environ.get("UPDATE_GOLDEN") == "1":
        comments = ""
        if path.exists():
            comments = "".join(l for l in path.read_text().splitlines(True) if l.startswith("#"))
        path.write_text(comments + text)
    if not path.exists():
        raise AssertionError(f"no golden trace {path}; rerun with UPDATE_GOLDEN=1")
    golden = "".join(l for l in path.read_text().splitlines(True) if not l.startswith("#"))
    if text != golden:
        raise AssertionError(f"{path.name} differs from the trace:\n{text}")
