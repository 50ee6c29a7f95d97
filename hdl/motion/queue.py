"""The frame queue: bytes of whole frames in block RAM, a frame visible only once committed."""

from amaranth import *
from amaranth.lib import stream, wiring
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..elements._checks import check_width

__all__ = ["QueueWriteSignature", "FrameQueue"]

#: The largest queue depth (bytes): the room a writer sees is 16 bits wide.
MAX_DEPTH = 1 << 15


class QueueWriteSignature(wiring.Signature):
    """The frame queue's write side, as its writer (:class:`~.link.FrameDecoder`) sees it.

    Members
    -------
    data : :py:`Out(8)`, en : :py:`Out(1)`
        A byte written in this clock.
    commit, rollback : :py:`Out(1)`
        Make visible / take back what was written since the last commit (after this clock's
        write).
    room : :py:`In(16)`
        Bytes that may still be written.
    """

    def __init__(self):
        super().__init__({"data": Out(8), "en": Out(1), "commit": Out(1), "rollback": Out(1),
                          "room": In(16)})

    def __eq__(self, other):
        return type(other) is type(self)

    def __hash__(self):
        return hash(type(self))

    def __repr__(self):
        return "QueueWriteSignature()"


class FrameQueue(wiring.Component):
    """A byte FIFO whose writer commits or drops what it wrote since its last commit.

    The frame decoder writes a frame's bytes as they arrive (:py:`w_en`), before it knows the
    frame is sound (:py:`w`, :class:`QueueWriteSignature`); :py:`w.commit` makes everything
    written so far visible to the reader, :py:`w.rollback` takes back everything written
    since the last commit. The reader sees
    committed bytes only, in order, on :py:`r`. The bytes live in a
    :class:`~amaranth.lib.memory.Memory` with a synchronous read port (block RAM; one clock
    from a read to its byte, the byte held in the port until taken), so the queue's storage
    costs no logic cells. Writes beyond :py:`w.room` are ignored: the writer must check it.

    Parameters
    ----------
    depth : :class:`int`
        Bytes, a power of 2 from 4 to 32768.

    Members
    -------
    w : :py:`In(QueueWriteSignature())`
        The writer: bytes, commit, rollback; the room left.
    r : :py:`Out(stream.Signature(8))`
        Committed bytes.
    r_level : :py:`Out(range(depth + 1))`
        Committed bytes not yet taken.

    Raises
    ------
    :exc:`TypeError`
        If ``depth`` is not a power of 2 from 4 to 32768.
    """

    def __init__(self, depth):
        check_width("Queue depth", depth, minimum=4)
        if depth & (depth - 1) or depth > MAX_DEPTH:
            raise TypeError(f"Queue depth must be a power of 2 up to {MAX_DEPTH}, "
                            f"not {depth!r}")
        self._depth = depth
        super().__init__({
            "w":        In(QueueWriteSignature()),
            "r":        Out(stream.Signature(8)),
            "r_level":  Out(range(depth + 1)),
        })

    @property
    def depth(self):
        return self._depth

    def elaborate(self, platform):
        m = Module()
        depth = self._depth
        bits = depth.bit_length() - 1
        m.submodules.storage = storage = Memory(shape=8, depth=depth, init=[])
        write = storage.write_port()
        read = storage.read_port(domain="sync")

        # Pointers one bit wider than the address, so that full and empty differ.
        written = Signal(bits + 1)          # next byte to write (speculative)
        committed = Signal(bits + 1)        # the reader may read up to here
        fetched = Signal(bits + 1)          # next byte to fetch from the memory
        taken = Signal(bits + 1)            # bytes given to the reader, the one held included
        held = Signal()                     # the read port holds a byte not yet taken

        room = Signal(range(depth + 1))
        m.d.comb += [
            room.eq(depth - (written - taken)[:bits + 1]),
            self.w.room.eq(room),
            write.addr.eq(written[:bits]),
            write.data.eq(self.w.data),
            write.en.eq(self.w.en & (room != 0)),
        ]
        written_next = Mux(write.en, written + 1, written)
        with m.If(self.w.rollback):
            m.d.sync += written.eq(committed)
        with m.Else():
            m.d.sync += written.eq(written_next)
        with m.If(self.w.commit):
            m.d.sync += committed.eq(written_next)

        fetch = Signal()
        m.d.comb += [
            fetch.eq((fetched != committed) & (~held | self.r.ready)),
            read.addr.eq(fetched[:bits]),
            read.en.eq(fetch),
            self.r.payload.eq(read.data),
            self.r.valid.eq(held),
            self.r_level.eq((committed - taken)[:bits + 1]),
        ]
        with m.If(fetch):
            m.d.sync += [fetched.eq(fetched + 1), held.eq(1)]
        with m.Elif(self.r.ready):
            m.d.sync += held.eq(0)
        with m.If(self.r.valid & self.r.ready):
            m.d.sync += taken.eq(taken + 1)
        return m
