"""``kontur send FILE.ngc --port DEVICE``: a program streamed to a board's controller.

The program is prepared as for ``kontur run`` (:func:`sim.host.machining.prepare`: read,
on the lattice, planned, its frames), checked whole before anything moves, then streamed over
the serial port (pyserial) under the protocol's flow control: at most the controller's queue
length of frames unanswered, an ``OUTCOME`` (or an ``ERROR``) answering each. A frame the
machine refuses or aborts, and every error it reports, is shown in the program's terms (its
line), and the stream stops (an ``ABORT`` is sent after an error, so nothing queued after it
moves). At the end the position is read back (``QUERY``) and compared with the program's end.
"""

import time

from hdl.motion.link import ERROR, ERRORS, OUTCOME, STATUS

from . import protocol

__all__ = ["send", "SendError", "open_port"]

OUTCOMES = ("done", "refused", "aborted")


class SendError(RuntimeError):
    """The machine did not run the program through: the message says where, in program
    lines."""


def open_port(device, baud, *, timeout=0.05):
    """Open ``device`` (a path, or any pyserial URL) at ``baud``, 8N1."""
    import serial
    return serial.serial_for_url(device, baudrate=baud, timeout=timeout)


def _where(lines, index):
    line = lines[index] if 0 <= index < len(lines) else None
    return f"line {line}" if line is not None else "the program's set-up (no program line)"


def send(job, port, *, progress=None, timeout=10.0, out=None):
    """Stream ``job``'s frames to the controller on ``port`` (an open pyserial port, or
    anything with ``write``, ``read`` and ``in_waiting``); return the final position read back
    (steps).

    ``progress``, if given, is called with the number of frames answered so far. ``timeout`` is
    how long (s) the machine may stay silent while frames are outstanding, ``out`` where to
    write what the machine says besides (a file).

    Raises
    ------
    SendError
        A frame refused or aborted, an error reply, silence, or a final position that is not
        the program's end; the message names the program line.
    """
    frames, lines = job.frames()
    parser = protocol.ReplyParser()
    window = job.machine.queue_frames
    sent = answered = 0
    heard = time.monotonic()
    status = None

    def replies():
        waiting = getattr(port, "in_waiting", 0)
        data = port.read(waiting or 1)
        return parser.feed(data) if data else []

    def fail(message):
        try:
            port.write(protocol.abort())
        finally:
            raise SendError(message)

    while answered < len(frames) or status is None:
        while sent < len(frames) and sent - answered < window:
            port.write(frames[sent])
            sent += 1
        if answered == len(frames) and status is None and sent == len(frames):
            port.write(protocol.query())
            sent += 1                              # the QUERY: answered by STATUS
        got = replies()
        if got:
            heard = time.monotonic()
        elif time.monotonic() - heard > timeout:
            fail(f"the machine has been silent for {timeout:g} s with {sent - answered} frames "
                 f"unanswered (the first from {_where(lines, answered)})")
        for reply in got:
            if reply.kind == OUTCOME:
                number, outcome = reply.fields
                if number != answered % 256:
                    fail(f"the machine answered frame {number}, expected "
                         f"{answered % 256} ({_where(lines, answered)})")
                if outcome != 0:
                    fail(f"{_where(lines, answered)}: the machine {OUTCOMES[outcome]} this "
                         f"move")
                answered += 1
                if progress is not None:
                    progress(answered)
            elif reply.kind == ERROR:
                (code,) = reply.fields
                first, last = _where(lines, answered), _where(lines, sent - 1)
                fail(f"the machine dropped a frame ({ERRORS.get(code, code)}) while frames from "
                     f"{first} to {last} were in flight; the rest is aborted")
            elif reply.kind == STATUS and answered == len(frames):
                status = reply.fields
            elif out is not None:
                out.write(f"kontur send: {reply}\n")
    x, y = status[0], status[1]
    if (x, y) != tuple(job.end):
        raise SendError(f"the machine ended at ({x}, {y}) steps, not at the program's end "
                        f"{tuple(job.end)}")
    return (x, y)
