"""The PIRATEbay link: wire protocol codec, transports, session, fault injection.

See ``docs/protocol.md`` for the byte-exact protocol. Nothing above this package
sees a byte or a raw integer: the protective layer holds a :class:`RobotLink`
(a :class:`~pirate_bt.robot.port.RobotPort`) made by :func:`open_link`. A simulated
bridge uses :class:`FrameCodec` and :class:`FrameDecoder` for the other direction.
"""

from pirate_bt.link.codec import (
    PROTOCOL_VERSION,
    Ack,
    AckStatus,
    BoardCounters,
    BoardStatus,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
    State,
    WireLayout,
    seq_newer,
)
from pirate_bt.link.faults import FaultSpec, FaultyLink, parse_fault_spec, split_fault_url
from pirate_bt.link.opening import open_link, wrap_link
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.session import Outcome, Request, Session, SessionConfig, SessionStats
from pirate_bt.link.transport import ByteLink, SerialLike, Transport, handshake, is_real_port

__all__ = [
    "PROTOCOL_VERSION",
    "Ack",
    "AckStatus",
    "BoardCounters",
    "BoardStatus",
    "BridgeFlags",
    "BridgeHeartbeat",
    "BulkSetpoints",
    "ByteLink",
    "Counters",
    "CountersRequest",
    "EStop",
    "EStopReset",
    "FaultSpec",
    "FaultyLink",
    "FrameCodec",
    "FrameDecoder",
    "Heartbeat",
    "Hello",
    "HelloReply",
    "Message",
    "MsgType",
    "Nack",
    "NackCode",
    "Outcome",
    "Request",
    "RobotLink",
    "SerialLike",
    "Session",
    "SessionConfig",
    "SessionStats",
    "Setpoint",
    "State",
    "Transport",
    "WireLayout",
    "handshake",
    "is_real_port",
    "open_link",
    "parse_fault_spec",
    "seq_newer",
    "split_fault_url",
    "wrap_link",
]
