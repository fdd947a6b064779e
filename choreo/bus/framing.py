"""The frame-resync core every decoder of a byte stream shares: the LX packets
(:class:`~choreo.bus.protocol.PacketDecoder`), the RRC board's frames and the LOBOT controller's.

Each framing starts its frames with a fixed two-byte header and tells a frame's length from the
bytes after it. Bytes that cannot start a frame, and frames failing their checksum, are skipped
one byte at a time, so a real header inside garbage or inside a damaged frame is found again.
Nothing here raises on any input.
"""

from __future__ import annotations

from typing import Generic, TypeVar

Frame = TypeVar("Frame")

MORE = 0  # frame_length: too few bytes have come to tell
NOT_A_FRAME = -1  # frame_length: the bytes after this header cannot start a frame


class ResyncDecoder(Generic[Frame]):
    """Bytes in, whole frames out, found again after garbage. Never raises.

    A framing says how long the frame at the start of the buffer is (:meth:`frame_length`),
    whether it is intact (:meth:`intact`: its checksum holds; one that fails is counted in
    ``bad_checksums``) and what it decodes to (:meth:`frame`)."""

    header: bytes  # two bytes

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.bad_checksums = 0
        self.discarded_bytes = 0  # garbage, and the first byte of each frame that was skipped

    def frame_length(self, buf: bytearray) -> int:
        """The whole length of the frame ``buf`` starts with (it starts with the header);
        ``MORE`` while too few bytes have come to tell, ``NOT_A_FRAME`` if it cannot be one."""
        raise NotImplementedError

    def intact(self, buf: bytearray, total: int) -> bool:
        """Whether the ``total`` bytes at the start of ``buf`` pass the framing's checksum."""
        return True

    def frame(self, buf: bytearray, total: int) -> Frame:
        """What the ``total`` bytes at the start of ``buf`` (a whole, intact frame) decode to."""
        raise NotImplementedError

    def reset(self) -> None:
        self._buffer.clear()

    def feed(self, data: bytes) -> list[Frame]:
        buf, header = self._buffer, self.header
        buf += data
        frames: list[Frame] = []
        while True:
            start = buf.find(header)
            if start < 0:
                # Keep a trailing first byte of the header: the second may be on its way.
                self._discard(len(buf) - (1 if buf[-1:] == header[:1] else 0))
                return frames
            self._discard(start)
            total = self.frame_length(buf)
            if total == NOT_A_FRAME:
                self._discard(1)
                continue
            if total == MORE or len(buf) < total:
                return frames
            if not self.intact(buf, total):
                self.bad_checksums += 1
                self._discard(1)
                continue
            frames.append(self.frame(buf, total))
            del buf[:total]

    def bytes_to_complete(self, expected_total: int) -> int:
        """How many more bytes finish the frame begun in the buffer: counted from its length
        once that has come, else assuming a frame of ``expected_total`` bytes (the reply the
        caller waits for). So a reader asks for exactly what is missing and does not block for
        bytes that never come."""
        buf = self._buffer  # after feed(): empty, a lone first header byte, or a frame begun
        total = self.frame_length(buf) if len(buf) >= len(self.header) else MORE
        return (total if total > 0 else expected_total) - len(buf)

    def _discard(self, count: int) -> None:
        self.discarded_bytes += count
        del self._buffer[:count]
