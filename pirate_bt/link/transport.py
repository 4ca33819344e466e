"""Byte transports on pyserial URLs, and the connect handshake.

One small class, :class:`Transport`, wraps anything pyserial's
:func:`serial.serial_for_url` opens: a real port (``/dev/ttyACM0``, ``COM3``),
``loop://``, ``socket://host:port``, ``spy://...`` and any scheme registered in
``serial.protocol_handler_packages`` (the simulator registers its own). The
port is opened with ``timeout=0`` so :meth:`Transport.read_available` never
blocks, and with a ``write_timeout`` always set so a wedged line cannot hang a
caller. Blocking reads loop on the injected :class:`~pirate_bt.clock.Clock`, so
with a simulated clock "waiting" advances simulated time.

:func:`handshake` is the connect sequence of ``docs/protocol.md``: wait out the
Arduino's DTR reset (real ports only), drain stale bytes, send ``HELLO`` and check
the reply's protocol version and layout digest.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import math
from typing import Protocol, runtime_checkable
from urllib.parse import parse_qs, urlsplit

import serial

from pirate_bt.clock import Clock
from pirate_bt.errors import (
    FrameError,
    InputError,
    LinkError,
    LinkTimeout,
    ProtocolMismatch,
)
from pirate_bt.link.codec import (
    MAX_WIRE_BYTES,
    PROTOCOL_MINOR,
    PROTOCOL_VERSION,
    BridgeFlags,
    FrameCodec,
    FrameDecoder,
    Hello,
    HelloReply,
    MsgType,
    Nack,
    NackCode,
    State,
    UnknownAckStatus,
    frame_time_s,
)
from pirate_bt.link.port_urls import scheme_problem

__all__ = [
    "ByteLink",
    "HelloRefused",
    "PortURLError",
    "SerialLike",
    "Transport",
    "handshake",
    "is_real_port",
]

_log = logging.getLogger(__name__)


class HelloRefused(ProtocolMismatch):
    """The bridge answered ``HELLO`` with a ``NACK``; :attr:`code` says which.

    A caller decides on the code, never on the message (a message may name other codes).
    """

    def __init__(self, message: str, code: NackCode) -> None:
        super().__init__(message)
        self.code = code

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (str(self), self.code))

    @classmethod
    def under_both_minors(cls, digest: int, asked: int) -> HelloRefused:
        """The layout refused (``BAD_LAYOUT``) under the minor asked and under 1.1 too:
        the layout is what differs, not the protocol's version."""
        return cls(
            f"the bridge refused the layout digest {digest:#010x} (BAD_LAYOUT) with protocol"
            f" 1.{asked} and again with 1.1: it was built for another robot description",
            NackCode.BAD_LAYOUT,
        )


_LOGGING = ("debug", "info", "warning", "error")
_OPTIONS = {
    "loop": ("logging",),
    "socket": ("logging",),
    "rfc2217": ("logging", "ign_set_control", "poll_modem", "timeout"),
}


class PortURLError(InputError, LinkError):
    """A URL of a scheme no handler here has (``bogus://x``), a ``spy://`` or ``hwgrep://``
    one that names nothing, a ``socket://`` or ``rfc2217://`` one that names no host and
    port, or a ``loop://`` one with an option it does not take: the user's input, exit 2
    (``InputError``), though still a ``LinkError`` to a caller that catches the failure
    to connect. :attr:`port_url` is the URL (a command line names its option by it)."""

    def __init__(self, message: str, port_url: str = "") -> None:
        super().__init__(message)
        self.port_url = port_url

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (str(self), self.port_url))


def network_url_problem(url: str) -> str | None:
    """What is wrong with a ``socket://`` or ``rfc2217://`` URL's host, port or
    options, or a ``loop://`` URL's options, or ``None``. pyserial's own message for
    these was garbled: a port of 99999 said *'debug|info|warning|error'*, no port *'<='
    not supported between instances of 'int' and 'NoneType'*, and ``?logging=verbose``
    *'verbose'*; on ``loop://`` both raised a ``KeyError`` (an internal error)."""
    scheme, _, rest = url.partition("://")
    if scheme not in _OPTIONS:
        return None
    form = f"give {scheme}://HOST:PORT"
    try:
        parts = urlsplit(url)
    except ValueError as exc:  # an unclosed or malformed [IPv6] host
        return f"no host and port in {rest!r} ({exc}); {form}"
    if scheme != "loop":  # loop:// reads its options only
        try:
            port = parts.port
        except ValueError:
            return f"the port {parts.netloc.rpartition(':')[2]!r} is not from 0 to 65535; {form}"
        if port is None or not parts.hostname:
            return f"no {'port' if parts.hostname else 'host'}; {form}"
    for option, values in parse_qs(parts.query, keep_blank_values=True).items():
        if option not in _OPTIONS[scheme]:
            return f"no option {option!r} (a {scheme}:// URL takes {', '.join(_OPTIONS[scheme])})"
        for value in values:
            if option == "logging" and value not in _LOGGING:
                return f"logging={value!r} is none of {', '.join(_LOGGING)}"
            if option == "timeout" and not _is_number(value):
                return f"timeout={value!r} is not a number of seconds"
    return None


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text)) and float(text) >= 0
    except ValueError:
        return False


def is_real_port(url: str) -> bool:
    """True when ``url`` names a device (no ``scheme://``): opening it resets an Arduino.

    Args:
        url: A pyserial URL or device path.

    Returns:
        Whether a DTR reset is to be expected.
    """
    return "://" not in url


@runtime_checkable
class SerialLike(Protocol):
    """What :class:`Transport` needs of a pyserial object (``serial.SerialBase``)."""

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes | memoryview, /) -> int | None: ...

    def close(self) -> None: ...

    def reset_input_buffer(self) -> None: ...


class ByteLink(Protocol):
    """The byte-level interface the session uses (a :class:`Transport` or a fault wrapper)."""

    @property
    def baud(self) -> int: ...

    def read_available(self) -> bytes: ...

    def write(self, data: bytes) -> None: ...

    def drain_input(self) -> int: ...

    def close(self) -> None: ...


DRAIN_LIMIT_BYTES = 1 << 20
"""The most :meth:`Transport.drain_input` discards in one call (a second of a
10 Mbit/s line; a serial bridge's buffer holds a few kilobytes)."""


class Transport:
    """A pyserial port with non-blocking reads and bounded writes.

    Args:
        port: An open pyserial object (anything with ``read``/``write``/``close``/
            ``reset_input_buffer``); set ``timeout=0`` and a ``write_timeout`` on it,
            or use :meth:`open`.
        baud: Line rate, used for timing figures.
        real_port: The port is a device whose opening resets an Arduino.
        url: The URL it was opened with, for messages.
    """

    def __init__(
        self, port: SerialLike, *, baud: int, real_port: bool = False, url: str = ""
    ) -> None:
        self.port = port
        self._baud = baud
        self.real_port = real_port
        self.url = url or repr(port)
        self.bytes_in = 0
        self.bytes_out = 0
        self._closed = False
        self._held = b""

    @classmethod
    def open(
        cls,
        url: str,
        *,
        baud: int,
        write_timeout_s: float | None = None,
    ) -> Transport:
        """Open ``url`` with :func:`serial.serial_for_url`.

        Args:
            url: Device path or pyserial URL.
            baud: Line rate in bit/s.
            write_timeout_s: Longest a write may block; default: 4 maximum frames at
                ``baud`` plus 50 ms.

        Returns:
            The open transport.

        Raises:
            PortURLError: the URL is malformed or of a scheme no handler here has (an
                ``InputError`` too).
            LinkError: the port cannot be opened.
        """
        if write_timeout_s is None:
            write_timeout_s = 4 * frame_time_s(MAX_WIRE_BYTES, baud) + 0.05
        problem = scheme_problem(url) or network_url_problem(url)
        if problem is not None:
            raise PortURLError(f"cannot open {url}: {problem}", url)
        try:
            port = serial.serial_for_url(
                url, baudrate=baud, timeout=0, write_timeout=write_timeout_s
            )
        except (serial.SerialException, ValueError, OSError, KeyError) as exc:
            # KeyError: pyserial formats some of its own messages wrongly
            raise LinkError(f"cannot open {url}: {exc}") from exc
        _log.info("opened %s at %d baud", url, baud)
        return cls(port, baud=baud, real_port=is_real_port(url), url=url)

    @property
    def baud(self) -> int:
        """Line rate in bit/s."""
        return self._baud

    def read_available(self) -> bytes:
        """Whatever bytes have arrived, without blocking (``b""`` if none).

        Raises:
            LinkError: the port failed (unplugged, closed).
        """
        held, self._held = self._held, b""
        try:
            data = self.port.read(4096)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"read from {self.url} failed: {exc}") from exc
        if data:
            self.bytes_in += len(data)
            return held + bytes(data)
        return held

    def read(self, n_bytes: int, timeout_s: float, clock: Clock, step_s: float = 0.001) -> bytes:
        """Up to ``n_bytes`` bytes, waiting at most ``timeout_s`` of ``clock`` time.

        Short reads are collected until ``n_bytes`` arrived or the time is up.

        Args:
            n_bytes: Bytes wanted.
            timeout_s: Longest wait.
            clock: The clock to wait on.
            step_s: Polling interval.

        Returns:
            The bytes read (fewer than ``n_bytes`` on timeout).

        Raises:
            LinkError: the port failed.
        """
        deadline = clock.now() + timeout_s
        out = bytearray()
        while True:
            chunk = self.read_available()
            take = n_bytes - len(out)
            out += chunk[:take]
            self._held = chunk[take:]  # a short read keeps the rest for the next call
            if len(out) >= n_bytes or clock.now() >= deadline:
                return bytes(out)
            clock.sleep(min(step_s, max(deadline - clock.now(), 0.0)))

    def write(self, data: bytes) -> None:
        """Write all of ``data``; partial writes are continued.

        Raises:
            LinkTimeout: the write did not complete within the write timeout.
            LinkError: the port failed.
        """
        view = memoryview(data)
        stalls = 0
        while view:
            try:
                n = self.port.write(view)
            except serial.SerialTimeoutException as exc:
                raise LinkTimeout(f"write to {self.url} timed out") from exc
            except (serial.SerialException, OSError) as exc:
                raise LinkError(f"write to {self.url} failed: {exc}") from exc
            written = len(view) if n is None else n
            if written == 0:
                stalls += 1
                if stalls > 3:
                    raise LinkTimeout(f"write to {self.url} made no progress")
            self.bytes_out += written
            view = view[written:]

    def drain_input(self) -> int:
        """Discard every byte received so far; return how many were read and dropped.

        At most :data:`DRAIN_LIMIT_BYTES`: a peer that sends faster than this reads (a
        flooding socket) would keep it reading for ever; what comes after is the
        handshake's to skip, as any noise.
        """
        dropped = len(self._held)
        self._held = b""
        with contextlib.suppress(serial.SerialException, OSError, AttributeError):
            self.port.reset_input_buffer()
        while dropped < DRAIN_LIMIT_BYTES and (chunk := self.read_available()):
            dropped += len(chunk)
        return dropped

    def close(self) -> None:
        """Close the port (idempotent)."""
        if not self._closed:
            self._closed = True
            try:
                self.port.close()
            except (serial.SerialException, OSError) as exc:
                _log.warning("closing %s: %s", self.url, exc)

    def __repr__(self) -> str:
        return f"Transport({self.url!r}, baud={self._baud})"


def handshake(
    link: ByteLink,
    codec: FrameCodec,
    clock: Clock,
    *,
    seq: int = 1,
    reset_wait_s: float = 0.0,
    reply_timeout_s: float = 0.25,
    attempts: int = 4,
    step_s: float = 0.001,
    minor: int = PROTOCOL_MINOR,
    decoder: FrameDecoder | None = None,
) -> HelloReply:
    """Connect: wait out a reset, drain stale bytes, exchange HELLO, check the reply.

    Args:
        link: An open transport.
        codec: The codec of the host's robot layout.
        clock: Clock to wait on (a simulated clock advances while waiting).
        seq: Sequence number of the HELLO.
        reset_wait_s: Time the bridge needs after the port opened (DTR reset); 0 for
            virtual ports.
        reply_timeout_s: Wait per HELLO attempt.
        attempts: HELLOs sent before giving up.
        step_s: Polling interval.
        minor: The protocol minor version the HELLO asks for.
        decoder: The decoder to read the reply with (reset first). Pass the one the
            session will read with: the reply is often followed, in the same read, by
            the first bytes of the next frame, which the session then completes
            instead of counting its rest as a bad frame.

    Returns:
        The bridge's reply.

    Raises:
        ProtocolMismatch: the bridge speaks another protocol version or layout
            (:class:`HelloRefused`, with the code, when it answered with a ``NACK``).
        LinkTimeout: no reply after all attempts.
        LinkError: the port failed.
    """
    if reset_wait_s > 0:
        _log.info("waiting %.2f s for the bridge to reset", reset_wait_s)
        clock.sleep(reset_wait_s)
    dropped = link.drain_input()
    if dropped:
        _log.info("drained %d stale bytes", dropped)
    if decoder is None:
        decoder = FrameDecoder(codec)
    decoder.reset()
    hello = Hello(seq, codec.layout.digest, minor)
    wire = b"\x00" + codec.encode(hello)  # the leading 0x00 flushes a half-received frame
    heard: collections.Counter[str] = collections.Counter()  # what came back instead
    other_seqs: set[int] = set()  # the seqs of HELLO_REPLYs to another HELLO than ours
    for attempt in range(1, attempts + 1):
        link.write(wire)
        deadline = clock.now() + reply_timeout_s
        while clock.now() < deadline:
            data = link.read_available()
            heard["bytes"] += len(data)
            heard["zeros"] += data.count(0)  # delimiters: a line in break reads as 0x00s
            for item in decoder.feed(data):
                if isinstance(item, FrameError):
                    if item.reason == "version":
                        raise ProtocolMismatch(
                            f"bridge speaks another protocol version ({item.detail}); "
                            f"host speaks {PROTOCOL_VERSION}"
                        )
                    if (
                        isinstance(item, UnknownAckStatus)
                        and item.seq == seq
                        and item.acked_type == MsgType.HELLO
                    ):  # answered, with a code the protocol does not have
                        raise ProtocolMismatch(
                            f"the bridge answered HELLO with an unknown {item.answer}"
                            f" {'status' if item.answer == 'ACK' else 'code'} {item.status}:"
                            " it does not follow the protocol"
                            f" {PROTOCOL_VERSION}.{minor}"
                        )
                    heard[f"bad:{item.reason}"] += 1
                    continue
                heard[f"frame:{item.TYPE.name}"] += 1
                if isinstance(item, State):  # the newest says whether it hears the host
                    heard["deaf"] = int(bool(item.flags & BridgeFlags.WATCHDOG))
                if isinstance(item, Nack) and item.seq == seq and item.acked_type == MsgType.HELLO:
                    if item.error is NackCode.BAD_LENGTH:
                        raise HelloRefused(
                            "the bridge does not understand this HELLO (BAD_LENGTH): it speaks "
                            f"another protocol minor version; host speaks "
                            f"{PROTOCOL_VERSION}.{minor}",
                            item.error,
                        )
                    if item.error is NackCode.BAD_LAYOUT:
                        raise HelloRefused(
                            f"the bridge refused the layout digest {codec.layout.digest:#010x} "
                            f"or protocol {PROTOCOL_VERSION}.{minor} (BAD_LAYOUT): it was "
                            "built for another robot description or protocol version",
                            item.error,
                        )
                    # docs/protocol.md: a bridge refuses HELLO only with BAD_LAYOUT or
                    # (another minor) BAD_LENGTH; any other code is not about the layout
                    raise HelloRefused(
                        f"the bridge refused HELLO ({item.error.name}): protocol "
                        f"{PROTOCOL_VERSION}.{minor} refuses a HELLO only with BAD_LAYOUT "
                        "(another layout or minor version) or BAD_LENGTH, so this bridge "
                        "does not follow the protocol",
                        item.error,
                    )
                if isinstance(item, HelloReply) and item.seq != seq:
                    other_seqs.add(item.seq)
                if isinstance(item, HelloReply) and item.seq == seq:
                    if item.minor != minor:
                        raise ProtocolMismatch(
                            f"bridge speaks protocol {PROTOCOL_VERSION}.{item.minor}; "
                            f"host speaks {PROTOCOL_VERSION}.{minor}"
                        )
                    if (
                        item.layout_digest != codec.layout.digest
                        or item.n_channels != codec.layout.n_channels
                        or item.n_motors != codec.layout.n_motors
                    ):
                        raise ProtocolMismatch(
                            f"bridge layout {item.layout_digest:#010x} "
                            f"({item.n_channels} channels, {item.n_motors} motors) differs from "
                            f"the robot description's {codec.layout.digest:#010x} "
                            f"({codec.layout.n_channels} channels, {codec.layout.n_motors} motors)"
                        )
                    _log.info(
                        "bridge answered HELLO (attempt %d): firmware %#06x, boot id %d, "
                        "session %d, flags %s",
                        attempt,
                        item.firmware,
                        item.boot_id,
                        item.sessions,
                        item.flags,
                    )
                    return item
            clock.sleep(min(step_s, max(deadline - clock.now(), 0.0)))
        # each attempt at INFO: the last one fails the connect with one line of its own
        _log.info("no HELLO reply (attempt %d of %d)", attempt, attempts)
    said = _heard(heard, seq, other_seqs)
    raise LinkTimeout(f"the bridge did not answer HELLO ({attempts} tries){said}")


def _heard(
    heard: collections.Counter[str], seq: int = 0, other_seqs: set[int] | None = None
) -> str:
    """What came back from a port that never answered HELLO (``seq``), for the error's
    line; ``other_seqs``: those of the ``HELLO_REPLY`` frames that came to another seq (a
    bridge that answers with another seq than asked: before 2026-11-30 they were named
    as if it never answered, *it sent 16 HELLO_REPLY, 96 STATE but never answered*)."""
    if not heard["bytes"]:
        return ": nothing came back"
    frames = [(k[6:], n) for k, n in sorted(heard.items()) if k.startswith("frame:")]
    bad = ", ".join(f"{k[4:]} {n}" for k, n in sorted(heard.items()) if k.startswith("bad:"))
    if not frames:
        empty = "0x00 bytes, no frame between them" if heard["zeros"] else "no delimiter"
        return (
            f": {heard['bytes']} bytes came back, none a good frame ({bad or empty}):"
            " another baud rate, or not a PIRATEbay?"
        )
    if all(name == "HELLO" for name, _ in frames):
        return ": only its own HELLO came back (an echo: a loopback?)"
    sent = [f"{n} {name}" for name, n in frames]
    if other_seqs:  # answers, but to another HELLO than the one sent
        shown = ", ".join(str(s) for s in sorted(other_seqs)[:3])
        to = f"each to seq {shown}" if len(other_seqs) == 1 else f"to seqs {shown}"
        more = ", ..." if len(other_seqs) > 3 else ""
        sent = [
            f"{part} ({to}{more}, not the HELLO's seq {seq})"
            if part.endswith(" HELLO_REPLY")
            else part
            for part in sent
        ]
    return (
        f": it sent {', '.join(sent)}"
        + (f" and bad frames ({bad})" if bad else "")
        + " but never answered"
        + (
            ": its STATE frames report its watchdog tripped (it hears nothing from the host:"
            " the line toward the bridge is down?)"
            if heard["deaf"]
            else ""
        )
    )
