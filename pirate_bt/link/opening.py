"""Opening a link: :func:`open_link` opens a URL (with optional faults), runs the
handshake and returns a ready :class:`~pirate_bt.link.robot_link.RobotLink`;
:func:`wrap_link` does the same for an already-open serial-like object or byte link.

The handshake's 1.1 fallback (a bridge that refuses a 1.2 ``HELLO`` with
``BAD_LAYOUT``) and the release of the e-stop latch a bridge boots with live here,
beside the link they open (split from ``robot_link`` with behaviour unchanged).
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

from pirate_bt.clock import Clock
from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    LinkError,
    LinkTimeout,
    ProtocolMismatch,
    kind_of,
    shown,
)
from pirate_bt.link.codec import BridgeFlags, FrameCodec, FrameDecoder
from pirate_bt.link.faults import FaultSpec, FaultyLink, parse_fault_spec, split_fault_url
from pirate_bt.link.hellos import reply_problem
from pirate_bt.link.inbound import unasked_text
from pirate_bt.link.messages import HelloReply, NackCode
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.session import Outcome, Session, SessionConfig
from pirate_bt.link.transport import (
    ByteLink,
    HelloRefused,
    SerialLike,
    Transport,
    handshake,
    is_real_port,
)
from pirate_bt.robot.description import RobotDescription

__all__ = ["open_link", "wrap_link"]

# the logger the link has always opened under
_log = logging.getLogger("pirate_bt.link.robot_link")
# tries of the boot latch release, when stale frames start new sessions under it
_RELEASE_TRIES = 4


def wrap_link(
    link: ByteLink | SerialLike,
    robot: RobotDescription,
    clock: Clock,
    *,
    faults: FaultSpec | str | None = None,
    config: SessionConfig | None = None,
    reset_wait_s: float = 0.0,
    threaded: bool = False,
    release_boot_latch: bool = True,
) -> RobotLink:
    """Handshake over an already-open link and return a :class:`RobotLink`.

    The bridge boots latched (docs/protocol.md, Boot). A latch that comes from boot
    (the hello is the first session since the bridge booted, which is what the DTR
    reset of a port opening gives) is released here, as part of the deliberate start;
    a latch an earlier session left on a bridge that was not reset stays.

    Args:
        link: A byte link (``Transport``, ``MemoryLink``, ...) or an open pyserial object
            (opened with ``timeout=0`` and a ``write_timeout``).
        robot: The robot description.
        clock: The clock all timing reads.
        faults: Faults to inject (a spec or its text).
        config: Session timing (default: derived from the robot).
        reset_wait_s: Time to wait for a bridge reset before the handshake.
        threaded: Drive the session from a reader thread (real ports, wall clock).
        release_boot_latch: Release a latch that comes from the bridge's boot.

    Returns:
        The connected link.

    Raises:
        ProtocolMismatch: other protocol version or layout.
        LinkTimeout: no answer to HELLO, or the release of the boot latch never
            acknowledged.
        InputError: a malformed fault spec.
    """
    byte_link: ByteLink
    if isinstance(link, Transport) or hasattr(link, "read_available"):
        byte_link = link  # type: ignore[assignment]
    else:
        byte_link = Transport(link, baud=robot.bridge.baud)
    if isinstance(faults, str):
        faults = parse_fault_spec(faults)
    if faults is not None and faults.active:
        byte_link = FaultyLink(byte_link, faults, clock)
    codec = FrameCodec.for_robot(robot)
    cfg = config or SessionConfig.from_robot(robot)
    # one decoder for the handshake and the session: the reply's read often ends in
    # the middle of the next frame, which the session's first read completes
    decoder = FrameDecoder(codec)

    def hello(seq: int, minor: int, reset_wait_s: float) -> HelloReply:
        return handshake(
            byte_link,
            codec,
            clock,
            seq=seq,
            reset_wait_s=reset_wait_s,
            # HELLO is resent every ack timeout, well inside the watchdog, so a lost
            # reply does not silence the host long enough to trip it; 16 tries, and
            # at least 0.4 s in all.
            reply_timeout_s=cfg.ack_timeout_s,
            attempts=max(16, math.ceil(0.4 / cfg.ack_timeout_s)),
            step_s=cfg.poll_step_s,
            minor=minor,
            decoder=decoder,
        )

    try:
        try:
            reply = hello(1, cfg.protocol_minor, reset_wait_s)
        except HelloRefused as refused:
            # on the code: the message of another refusal names BAD_LAYOUT too
            if cfg.protocol_minor == 1 or refused.code is not NackCode.BAD_LAYOUT:
                raise
            # A 1.1 bridge refuses a 1.2 HELLO (NACK BAD_LAYOUT, as for another layout):
            # ask once more for 1.1; if the layout is what it refuses, that fails too.
            _log.info("the bridge refused protocol 1.%d; asking for 1.1", cfg.protocol_minor)
            asked, cfg = cfg.protocol_minor, replace(cfg, protocol_minor=1)
            try:
                reply = hello(2, 1, 0.0)
            except HelloRefused as again:  # refused under both: the layout differs
                if again.code is not NackCode.BAD_LAYOUT:
                    raise
                raise HelloRefused.under_both_minors(codec.layout.digest, asked) from None
        problem = reply_problem(reply, robot.bridge.baud)  # as a new session's reply
        if problem is not None:
            raise ProtocolMismatch(problem)
    except BaseException:
        byte_link.close()
        raise
    session = Session(
        byte_link, codec, clock, cfg, first_seq=reply.seq + 1, hello_reply=reply, decoder=decoder
    )
    if threaded:
        session.start_reader(cfg.poll_step_s)
    kept = ""
    if reply.flags & BridgeFlags.ESTOP:
        if release_boot_latch and reply.sessions == 1:
            try:
                kept = _release_boot_latch(session, reply.boot_id, cfg.give_up_s)
            except BaseException:
                session.close()
                raise
        else:
            _log.warning("the bridge's e-stop is latched (from an earlier session); reset it")
            kept = (
                "latched in an earlier session (reset it)"
                if release_boot_latch
                else "latched at the handshake, and this link was opened not to release it"
            )
    robot_link = RobotLink(robot, session)
    robot_link.latch_kept = kept
    return robot_link


def _release_boot_latch(session: Session, boot_id: int, give_up_s: float) -> str:
    """Release the latch the bridge booted with (see :func:`wrap_link`).

    Returns:
        ``""`` when released; else why the latch stays, for people.

    Raises:
        LinkTimeout: the release was never acknowledged.
        LinkError: it was answered ``ACK STALE``.
        ProtocolMismatch: it was answered with an ``ACK`` status the protocol does not
            have (or another mismatch ended the session meanwhile).
    """
    started_s = session.clock.now()
    for _ in range(_RELEASE_TRIES):
        try:
            req = session.wait(session.estop_reset())
        except ProtocolMismatch as exc:  # an unknown ACK status, say: not a slow line
            raise ProtocolMismatch(f"releasing the boot latch: {exc}") from None
        session.take_failures()
        if req.outcome is not Outcome.FAILED:
            break
        hello = session.pending_hello
        if hello is None:
            # not acknowledged within the retry budget (a lossy link): the release is
            # idempotent (a bridge not latched acknowledges it too), so ask again
            _log.info("releasing the boot latch again: it was not acknowledged")
            continue
        # A NO_SESSION frame started a new session while the release was in flight. Its
        # reply with the same boot id: a stale boot frame (a reordering link), not a
        # reset, so the latch is still the boot's own: release it again.
        session.wait(hello)
        last = session.last_hello_reply
        if hello.outcome is not Outcome.ACKED or last is None or last.boot_id != boot_id:
            break  # a genuine reset: its latch stays (an operator decides)
        _log.info("releasing the boot latch again: a stale frame started a new session")
    if req.outcome is Outcome.ACKED:
        _log.info("released the latch the bridge booted with")
        return ""
    if req.outcome is Outcome.NACKED or session.bridge_resets:
        # refused, or the bridge reset meanwhile: the latch stays, a latched e-stop
        nack = req.nack.name if req.nack else ""
        _log.warning("the bridge's boot latch was not released: %s %s", req.outcome.value, nack)
        if req.outcome is Outcome.NACKED:
            return f"the release of its boot latch was refused (NACK {nack})".replace(" )", ")")
        return "the bridge reset while its boot latch was released, and booted latched again"
    elif req.outcome is Outcome.STALE:
        # answered at once, but not applied: no e-stop overtook it, so the bridge's
        # duplicate filter is ahead of the HELLO it just took. Not a slow round trip.
        raise LinkError(
            "the bridge answered the release of its boot latch ACK STALE (not applied),"
            " right after the HELLO that reset its duplicate filter: a bridge that does"
            " not follow the protocol?"
        )
    else:
        # never acknowledged (the round trip outlasts the retry budget, or the link
        # failed, or the bridge answers with another seq): a link error, not an e-stop
        # the operator has to reset
        unasked = session.answers_unasked_since(started_s)
        why = f"the bridge {unasked_text(unasked)}" if unasked else "round trip too long?"
        raise LinkTimeout(
            "the bridge did not acknowledge the release of its boot latch within "
            f"{give_up_s:.3g} s ({req.outcome.value}; {why})"
        )


def open_link(
    url: str,
    robot: RobotDescription,
    clock: Clock,
    *,
    faults: FaultSpec | str | None = None,
    config: SessionConfig | None = None,
    reset_wait_s: float | None = None,
    threaded: bool | None = None,
    write_timeout_s: float | None = None,
    release_boot_latch: bool = True,
) -> RobotLink:
    """Open ``url`` (any pyserial URL), connect and return a :class:`RobotLink`.

    Fault options in the URL (``?faults=drop=0.1&fault_seed=3``) are applied unless
    ``faults`` is given.

    Args:
        url: Device path or pyserial URL (``loop://``, ``socket://``, ``spy://``, a
            registered simulator scheme, ...).
        robot: The robot description (layout, baud, reset time, watchdog).
        clock: The clock all timing reads.
        faults: Faults to inject (a spec or its text).
        config: Session timing (default: derived from the robot).
        reset_wait_s: Wait for the Arduino's DTR reset; default ``bridge.reset_time``
            for device paths and 0 for URLs.
        threaded: Use a reader thread; default: on a wall clock, for device paths and
            network URLs (``socket://``, ``rfc2217://``, and ``spy://`` around one),
            so heartbeats go out while the program does not call in (a bridge behind
            a serial-over-TCP adapter trips its watchdog otherwise).
        write_timeout_s: Longest a write may block (default from the baud rate).
        release_boot_latch: Release a latch that comes from the bridge's boot (the DTR
            reset of this very opening); see :func:`wrap_link`.

    Returns:
        The connected link.

    Raises:
        LinkError: cannot open, other protocol/layout (``ProtocolMismatch``) or no
            answer (``LinkTimeout``).
        InputError: a malformed fault spec, or an argument of the wrong type or value
            (``ArgumentTypeError``, ``ArgumentValueError``), refused before the port
            opens; a port is never left open when this raises.
    """
    _check_arguments(url, robot, clock, config, reset_wait_s, write_timeout_s, threaded)
    clean_url, url_faults = split_fault_url(url)
    if faults is None:
        faults = url_faults
    if isinstance(faults, str):  # parsed before the port opens: a bad spec left it open
        faults = parse_fault_spec(faults)
    elif faults is not None and not isinstance(faults, FaultSpec):
        raise ArgumentTypeError(
            f"faults: give a link fault spec (text such as 'drop=0.05') or None,"
            f" not {kind_of(faults)}"
        )
    real = is_real_port(clean_url)
    if reset_wait_s is None:
        reset_wait_s = robot.bridge.reset_time if real else 0.0
    if threaded is None:
        threaded = not clock.is_simulated and (real or _over_a_wire(clean_url))
    transport = Transport.open(clean_url, baud=robot.bridge.baud, write_timeout_s=write_timeout_s)
    try:
        return wrap_link(
            transport,
            robot,
            clock,
            faults=faults,
            config=config,
            reset_wait_s=reset_wait_s,
            threaded=threaded,
            release_boot_latch=release_boot_latch,
        )
    except LinkTimeout as exc:
        transport.close()
        raise LinkTimeout(f"{clean_url}: {exc}") from exc
    except BaseException:
        transport.close()  # idempotent: the handshake's failure closed it already
        raise


_MAX_RESET_WAIT_S = 3600.0


def _check_arguments(
    url: object,
    robot: object,
    clock: object,
    config: object,
    reset_wait_s: object,
    write_timeout_s: object,
    threaded: object,
) -> None:
    """Refuse a wrong argument of :func:`open_link` in one line naming it (``None``
    for ``url`` was *'NoneType' object has no attribute 'partition'*)."""
    if not isinstance(url, str):
        raise ArgumentTypeError(f"url: give a port or pyserial URL as text, not {kind_of(url)}")
    if not url.strip():
        raise ArgumentValueError("url: give a port or pyserial URL, not empty text")
    if not isinstance(robot, RobotDescription):
        raise ArgumentTypeError(
            f"robot: give a RobotDescription (pirate_bt.robot.load_robot), not {kind_of(robot)}"
        )
    if not isinstance(clock, Clock):
        raise ArgumentTypeError(f"clock: give a Clock (SimClock, WallClock), not {kind_of(clock)}")
    if config is not None and not isinstance(config, SessionConfig):
        raise ArgumentTypeError(f"config: give a SessionConfig or None, not {kind_of(config)}")
    if threaded is not None and not isinstance(threaded, bool):
        raise ArgumentTypeError(f"threaded: give True, False or None, not {shown(threaded)}")
    for option, value, least, most in (
        ("reset_wait_s", reset_wait_s, 0.0, _MAX_RESET_WAIT_S),
        ("write_timeout_s", write_timeout_s, 1e-6, _MAX_RESET_WAIT_S),
    ):
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ArgumentTypeError(f"{option}: give seconds (a number), not {kind_of(value)}")
        if not least <= value <= most:  # nan too
            raise ArgumentValueError(
                f"{option}: {shown(value)} is not a number of seconds from {least:g} to {most:g}"
            )


_WIRE_SCHEMES = ("socket://", "rfc2217://", "spy://")


def _over_a_wire(url: str) -> bool:
    """A URL to another process or device that keeps its own time (a bridge behind
    ser2net, a simulator served on TCP), not an in-process one (``loop://``, ``sim://``)."""
    return url.lower().startswith(_WIRE_SCHEMES)
