"""What Grbl 1.1 says, as its interface documents give it (gnea/grbl ``doc/markdown/
interface.md``, ``commands.md``, ``doc/csv/*.csv``): the welcome, the real-time bytes, the
error and alarm codes, the settings, the reports; and the map from kontur's refusals of a
G-code line to Grbl's error codes. Pure: no state, no I/O.
"""

import math
import re

__all__ = ["VERSION", "WELCOME", "RX_BUFFER", "PLANNER_BLOCKS", "LINE_BUFFER", "REALTIME",
           "STATUS", "HOLD", "RESUME", "RESET", "JOG_CANCEL", "FEED_OVERRIDES",
           "RAPID_OVERRIDES", "SPINDLE_OVERRIDES", "ERRORS", "ALARMS", "HELP", "clean_line",
           "error_code", "number", "status_report"]

VERSION = "1.1h"
WELCOME = f"Grbl {VERSION} ['$' for help]"
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"

#: The serial receive buffer a character-counting sender fills (bytes), the planner's blocks
#: (Grbl reports one fewer free: ``Bf:15,128`` when idle), a line's characters at most.
RX_BUFFER = 128
PLANNER_BLOCKS = 16
LINE_BUFFER = 80

STATUS, HOLD, RESUME, RESET = ord("?"), ord("!"), ord("~"), 0x18
JOG_CANCEL, SAFETY_DOOR = 0x85, 0x84
FEED_OVERRIDES = {0x90: ("set", 100), 0x91: ("add", 10), 0x92: ("add", -10),
                  0x93: ("add", 1), 0x94: ("add", -1)}
RAPID_OVERRIDES = {0x95: 100, 0x96: 50, 0x97: 25}
SPINDLE_OVERRIDES = {0x99: ("set", 100), 0x9A: ("add", 10), 0x9B: ("add", -10),
                     0x9C: ("add", 1), 0x9D: ("add", -1)}
#: Every byte taken at once, never queued: ``?``, ``!``, ``~``, ctrl-X and 0x80-0xFF (the
#: overrides, jog cancel, safety door, the toggles; Grbl drops the others of that range).
REALTIME = frozenset((STATUS, HOLD, RESUME, RESET, *range(0x80, 0x100)))
#: Override limits (Grbl's config.h defaults).
OVERRIDE_MIN, OVERRIDE_MAX = 10, 200

#: Grbl's error codes (doc/csv/error_codes_en_US.csv), those kontur gives.
ERRORS = {
    1: "Expected command letter", 2: "Bad number format", 3: "Invalid statement",
    4: "Value < 0", 5: "Setting disabled", 8: "Not idle", 9: "G-code lock",
    10: "Homing not enabled", 11: "Line overflow", 15: "Travel exceeded",
    16: "Invalid jog command", 20: "Unsupported command", 21: "Modal group violation",
    22: "Undefined feed rate", 23: "Command value not integer", 24: "Axis command conflict",
    25: "Word repeated", 26: "No axis words", 28: "Value word missing",
    30: "G53 invalid motion mode", 31: "Axis words exist",
    33: "Invalid target", 34: "Arc radius error", 35: "No offsets in plane",
    36: "Unused words",
}
#: Grbl's alarm codes (doc/csv/alarm_codes_en_US.csv), those kontur raises.
ALARMS = {2: "Soft limit", 3: "Reset while in motion"}


def number(value, places=3):
    """A number as Grbl prints it: ``places`` decimals (0: an integer, no point)."""
    if places == 0:
        return str(int(round(value)))
    text = f"{value:.{places}f}"
    return "0." + "0" * places if text == "-0." + "0" * places else text


def status_report(state, position, *, work=False, buffer=None, feed=0.0, speed=0.0,
                  overrides=None, inches=False, offset=None, accessories="", pins=""):
    """``<State|MPos:x,y,z|Bf:b,r|FS:f,s|Pn:..|WCO:...|Ov:f,r,s|A:..>``, in Grbl 1.1's order
    (its report.c): WPos with ``work``; Bf when ``buffer`` is given; Pn when ``pins`` (the
    active inputs' letters) are not empty; WCO when ``offset`` is given; Ov when
    ``overrides`` are, with A when ``accessories`` (its letters) are not empty. Positions in
    mm (inches with ``inches``, 4 decimals as Grbl), the feed in mm/min (in/min)."""
    scale, places = (1 / 25.4, 4) if inches else (1.0, 3)
    fields = [state, ("WPos:" if work else "MPos:")
              + ",".join(number(c * scale, places) for c in position)]
    if buffer is not None:
        fields.append(f"Bf:{buffer[0]},{buffer[1]}")
    fields.append(f"FS:{number(feed * scale, 0)},{number(speed, 0)}")
    if pins:
        fields.append(f"Pn:{pins}")
    if offset is not None:
        fields.append("WCO:" + ",".join(number(c * scale, places) for c in offset))
    if overrides is not None:
        fields.append("Ov:" + ",".join(str(v) for v in overrides))
        if accessories:
            fields.append(f"A:{accessories}")
    return "<" + "|".join(fields) + ">"


def clean_line(raw):
    """A received line as Grbl's protocol layer hands it on: spaces and control characters
    dropped, ``( )`` and ``;`` comments removed, letters upper case (a ``$J=`` jog's too).
    Returns the text Grbl would parse; its length is what the line buffer holds."""
    out, comment = [], None
    for ch in raw:
        if comment == "(":
            if ch == ")":
                comment = None
            continue
        if comment == ";":
            break
        if ch == "(":
            comment = "("
        elif ch == ";":
            comment = ";"
        elif ch > " " and ch != "\x7f":
            out.append(ch.upper())
    return "".join(out)


# ---- kontur's refusals as Grbl's codes -------------------------------------------------

#: A G-code refusal's reason (kontur.gcode, kontur.planner) and its Grbl code: the first
#: pattern the reason matches. Grbl's descriptions: error_codes_en_US.csv.
_REFUSALS = [
    (r"^cannot read '[A-Za-z]", 2),              # a letter with no number: bad number format
    (r"^cannot read", 1),                        # no letter: expected command letter
    (r"characters, more than the", 2),           # a number too long to read
    (r"comment|closes no", 1),
    (r"^unknown code [GM]-?\d*\.\d", 23),         # G1.5: Grbl's mantissa check
    (r"a tool number is a whole number", 23),
    (r"^unknown word|^unknown code|only the XY plane|compensation", 20),
    (r"given twice", 25),
    (r"^two .* codes in one block", 21),
    (r"both use the axis words", 24),
    (r"no feed rate|feed .* below the lowest|feed must be positive, not F0*\.?0*$", 22),
    (r"feed must be positive|must not be negative", 4),
    (r"coordinates without a motion code", 31),
    (r"no code in this block takes [PL]|belong to arcs|not both|turns are a whole number"
     r"|plane \(G1[789]\) takes", 36),
    (r"no code in this block takes", 20),        # Q, H: letters Grbl does not know
    (r"^G(4|10) needs [LP]", 28),                # a value word missing
    (r"needs an axis word", 26),
    (r"^G53 .* not an arc", 30),
    (r"needs the centre", 35),
    (r"radius zero \(R0\)|less than half the distance", 34),
    (r"by radius \(R\) cannot end where it starts", 33),
]


def error_code(reason, default=33):
    """Grbl's error code for kontur's refusal of a line (``reason``, the reader's or the
    planner's): the first pattern of :data:`_REFUSALS` it matches, else ``default``: 33
    (invalid target) for a motion the machine cannot make (an arc's radii beyond the
    tolerance, a sweep the lattice cannot keep, a move too long for the engines), 20
    (unsupported command) for the rest of what the reader refuses (LinuxCNC's expressions
    and parameters, which Grbl has not)."""
    for pattern, code in _REFUSALS:
        if re.search(pattern, reason):
            return code
    return default


def parse_setting(text):
    """``$N=value`` (cleaned) as ``(N, value)``; ``None`` for a malformed one (Grbl: error 2
    for a number it cannot read, 3 for a statement it cannot)."""
    match = re.fullmatch(r"\$(\d+(?:\.\d*)?)=([+-]?(?:\d+\.?\d*|\.\d+))", text)
    if not match:
        return None
    value = float(match.group(2))
    return (int(float(match.group(1))), value) if math.isfinite(value) else None
