"""The streaming frame decoder: bytes as they arrive in, messages and frame errors out.

This module sits below :mod:`pirate_bt.link.codec` and does not import it: the
decoder needs only a codec's two frame steps, spelled out as :class:`MessageCodec`
(which :class:`~pirate_bt.link.codec.FrameCodec` satisfies). ``codec`` re-exports
:class:`FrameDecoder` and :func:`encode_many`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Protocol, TypeVar

from pirate_bt.errors import FrameError
from pirate_bt.link.framing import MAX_WIRE_BYTES, cobs_decode
from pirate_bt.link.messages import Message

__all__ = ["FrameDecoder", "MessageCodec", "encode_many"]

_T = TypeVar("_T")


class MessageCodec(Protocol):
    """What the decoder needs of a codec (:class:`~pirate_bt.link.codec.FrameCodec`)."""

    def encode(self, msg: Message) -> bytes:
        """The wire bytes of ``msg``, delimiter included."""
        ...

    def decode_body(self, body: bytes) -> Message:
        """The message of a COBS-decoded frame body (raises :class:`FrameError`)."""
        ...


class FrameDecoder:
    """Streaming decoder: feed it bytes as they arrive, get messages and frame errors back.

    Bytes are collected up to each 0x00 delimiter. A frame longer than the maximum
    is reported once as ``oversize`` and skipped up to the next delimiter, so a
    lost delimiter costs at most two frames. Empty frames (two delimiters in a row,
    which a sender may use to flush the line) are ignored silently.

    Args:
        codec: The codec for the robot's layout.
    """

    def __init__(self, codec: MessageCodec) -> None:
        self.codec = codec
        self._buf = bytearray()
        self._overflow = False  # pragma: no mutate (None is falsy as False is)

    def reset(self) -> None:
        """Forget any partial frame (after draining stale bytes)."""
        self._buf.clear()
        self._overflow = False  # pragma: no mutate (None is falsy as False is)

    @property
    def pending_bytes(self) -> int:
        """Bytes of an unfinished frame held."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[Message | FrameError]:
        """Add received bytes; return every frame they complete, in order.

        Never raises for any input: a bad frame comes back as a :class:`FrameError`.

        Args:
            data: Bytes read from the line (any length, any content).

        Returns:
            Decoded messages and frame errors, in arrival order.
        """
        return self._feed(data, self.codec.decode_body)

    def _feed(self, data: bytes, decode_body: Callable[[bytes], _T]) -> list[_T | FrameError]:
        out: list[_T | FrameError] = []
        if not data:
            return out
        # A plain loop filling a list, with the codec's two steps called directly: a
        # generator and the extra decode() layer cost about a microsecond per frame.
        parts = data.split(b"\x00")
        limit = MAX_WIRE_BYTES - 1
        for part in parts[:-1]:
            if self._overflow:
                self._overflow = False  # pragma: no mutate (None is falsy as False is)
                self._buf.clear()
                continue
            if self._buf:
                self._buf += part
                frame = bytes(self._buf)
                self._buf.clear()
            else:
                frame = part
            if not frame:
                continue
            if len(frame) > limit:
                out.append(FrameError("oversize", f"{len(frame)} bytes before the delimiter"))
                continue
            try:
                out.append(decode_body(cobs_decode(frame)))
            except FrameError as exc:
                out.append(exc)
            except Exception as exc:  # defensive: the decoder contract is FrameError only
                out.append(FrameError("internal", f"{type(exc).__name__}: {exc}"))
        tail = parts[-1]
        if self._overflow:
            return out
        self._buf += tail
        if len(self._buf) > limit:
            self._buf.clear()
            self._overflow = True
            out.append(FrameError("oversize", f"more than {limit} bytes without a delimiter"))
        return out

    def iter_feed(self, data: bytes) -> Iterator[Message | FrameError]:
        """Like :meth:`feed`, as an iterator (the bytes are all decoded at the first step)."""
        return iter(self.feed(data))


def encode_many(codec: MessageCodec, msgs: Sequence[Message]) -> bytes:
    """Concatenate the wire bytes of several messages (tests and simulators)."""
    return b"".join(codec.encode(m) for m in msgs)
