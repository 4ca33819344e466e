"""The host link's two implementations, fed the same bytes: the bridge firmware's C and
the Python codec, as an outside implementer would compare them.

The C is ``firmware/piratebay/host/link_probe.c`` (``make link-probe``): the bridge's
receiver (``frame.c``, ``cobs.c``, ``crc.h``), its parser and rules (``protocol.c``)
and its encoder, as flashed, around ``host/host_hal.c``, built with
``-fsanitize=address,undefined`` (a sanitizer report ends the program, and the test
with it). The Python side is ``pirate_bt.link``: :class:`~pirate_bt.link.raw.RawFrameDecoder`
and :class:`~pirate_bt.link.codec.FrameCodec` as a bridge would use them, the
reference bridge (:class:`~pirate_bt.sim.bridge.SimBridge`) and the host's
:class:`~pirate_bt.link.codec.FrameDecoder`. Three comparisons:

- frames from the host: valid ones of every host type from :class:`FrameCodec`, the
  same mutated (bit flips, cuts, extensions, other versions, zero bytes, ``0xFF``
  runs, bodies of 254 and 255 bytes, payloads one byte off) and random bytes, to
  the C receiver and to the Python decoders: the same frames accepted, the same
  dropped as a CRC error or a frame error, the same fields;
- a conversation: sessions, the duplicate filter, every request with good and bad
  fields, resets and hostile bytes, to the C bridge and the reference bridge: the
  same answers (ACK, NACK, HELLO_REPLY, COUNTERS) and the same STATE flags,
  ``ack_seq`` and board status, every frame the C sends taken by the host's decoder;
- frames the C encodes (``frame_encode``) decoded by the host: the fields the C put
  in, and the bytes the Python codec writes for the same message.

Here a few thousand cases (a few seconds); ``run_probe`` with larger counts is the
long run (see the module's end).
"""

from __future__ import annotations

import os
import random
import shutil
import struct
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import pytest
from codec_diff_frames import (
    BOARDS,
    CODEC,
    DIGEST,
    N_MOTORS,
    ROBOT,
    body_of,
    host_message,
    hostile_stream,
    mutate,
    random_bytes,
    wire,
)

from pirate_bt.errors import FrameError
from pirate_bt.link.codec import (
    MODE_CODES,
    BridgeFlags,
    BridgeHeartbeat,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Hello,
    HelloReply,
    Message,
    MsgType,
    State,
)
from pirate_bt.link.raw import HOST_TYPES, RawFrame, RawFrameDecoder, parse_raw

ROOT = Path(__file__).resolve().parents[1]
FIRMWARE = ROOT / "firmware" / "piratebay"
N_CHANNELS = len(ROBOT.state_channels())
HOST_SIZES = {
    MsgType.HELLO: 5,
    MsgType.SETPOINT: 4,
    MsgType.BULK_SETPOINTS: 3 * N_MOTORS,
    MsgType.HEARTBEAT: 0,
    MsgType.ESTOP: 0,
    MsgType.ESTOP_RESET: 0,
    MsgType.COUNTERS_REQUEST: 0,
}
STEP_MS = 30  # a conversation step: its bytes, the answers, the STATE of 3 periods
SANITIZE = "-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"


# -- the C program ------------------------------------------------------------------------------


def build_probe(build: Path) -> Path:
    """``make link-probe`` into ``build`` (the layout header written first, from the
    default robot, as ``make`` would). Raises RuntimeError when the build fails."""
    from pirate_bt.robot.header import render_header

    robot_file = ROOT / "hardware" / "pirate.yaml"
    build.mkdir(parents=True, exist_ok=True)
    (build / "robot.path").write_text(f"{robot_file}\n")
    (build / "layout.h").write_text(render_header(ROBOT, str(robot_file)))
    old = robot_file.stat().st_mtime - 1
    os.utime(build / "robot.path", (old, old))
    done = subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(FIRMWARE),
            "link-probe",
            f"BUILD={build}",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
            f"PROBE_SANITIZE={SANITIZE}",
        ],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "MAKEFLAGS": ""},
    )
    if done.returncode != 0:
        raise RuntimeError(done.stdout + done.stderr)
    return build / "link_probe"


def run_c(program: Path, records: bytes, timeout: float = 300) -> list[str]:
    """Run the probe on ``records``; its output lines. Fails on any sanitizer report."""
    done = subprocess.run(
        [str(program)],
        input=records,
        capture_output=True,
        timeout=timeout,
        check=False,
        env={
            **os.environ,
            "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=0:exitcode=99",
            "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1:exitcode=98",
        },
    )
    err = done.stderr.decode(errors="replace")
    assert done.returncode == 0, f"link_probe exit {done.returncode}:\n{err[-4000:]}"
    assert "runtime error" not in err and "Sanitizer" not in err, err[-4000:]
    return done.stdout.decode().splitlines()


def rec_f(data: bytes) -> bytes:
    return b"F" + struct.pack("<H", len(data)) + data


def rec_w(data: bytes, us: int) -> bytes:
    return b"W" + struct.pack("<H", len(data)) + data + struct.pack("<I", us)


def rec_e(kind: int, seq: int, arg: int, payload: bytes) -> bytes:
    return b"E" + struct.pack("<BHBB", kind, seq, arg, len(payload)) + payload


# -- 1. the receivers ---------------------------------------------------------------------------


def c_receiver(program: Path, records: list[bytes]) -> list[tuple[str, bytes]]:
    lines = run_c(program, b"".join(rec_f(r) for r in records))
    return [(line[0], bytes.fromhex(line[2:])) for line in lines if line != "."]


def fields_of(raw: RawFrame) -> tuple[int, int, int, bytes]:
    return raw.type, raw.seq, raw.arg, raw.payload


def check_host_decoding(msg: Message | FrameError, raw: RawFrame) -> str | None:
    """Where the Python codec, decoding an accepted frame of a host type for a bridge,
    parts from the C's reading of it; None when it does not."""
    size = HOST_SIZES.get(MsgType(raw.type)) if raw.type in HOST_TYPES else None
    if size is None:
        return None  # the C answers UNKNOWN_TYPE; a decoder of both directions differs
    if len(raw.payload) != size:
        ok = isinstance(msg, FrameError) and msg.reason == "length"
        return None if ok else f"bad length not refused: {msg!r}"
    if isinstance(msg, FrameError):
        # a mode code outside the table: the C answers BAD_MODE, a later step
        codes = set(MODE_CODES.values())
        if raw.type == MsgType.SETPOINT and raw.payload[1] not in codes:
            return None if msg.reason == "value" else repr(msg)
        if raw.type == MsgType.BULK_SETPOINTS and any(
            m not in codes and m != 0xFF for m in raw.payload[0::3]
        ):
            return None if msg.reason == "value" else repr(msg)
        return f"refused {msg!r}"
    if raw.type != msg.TYPE or msg.seq != raw.seq:
        return f"header {msg!r}"
    arg, payload = CODEC.encode_payload(msg)
    if payload != raw.payload or (raw.type == MsgType.SETPOINT and arg != raw.arg):
        return f"fields {msg!r}"
    return None


def compare_receivers(program: Path, records: list[bytes]) -> dict[str, int]:
    """The C receiver against RawFrameDecoder and FrameCodec on ``records``; counts."""
    c = c_receiver(program, records)
    raw_dec, msg_dec = RawFrameDecoder(CODEC), FrameDecoder(CODEC)
    py: list[RawFrame | FrameError] = []
    msgs: list[Message | FrameError] = []
    for record in records:
        py += raw_dec.feed_raw(record)
        msgs += msg_dec.feed(record)
    assert len(py) == len(msgs)
    counts = {"records": len(records), "frames": len(c), "K": 0, "C": 0, "B": 0}
    assert len(c) == len(py), f"C completed {len(c)} frames, Python {len(py)}"
    for i, ((tag, body), item, msg) in enumerate(zip(c, py, msgs, strict=True)):
        counts[tag] += 1
        where = f"frame {i}: C {tag} {body.hex()}, Python {item!r}"
        if tag == "K":
            assert isinstance(item, RawFrame), where
            assert fields_of(item) == fields_of(parse_raw(body)), where
            problem = check_host_decoding(msg, item)
            assert problem is None, f"{where}: FrameCodec {problem}"
        elif tag == "C":
            assert isinstance(item, FrameError) and item.reason == "crc", where
        else:
            assert isinstance(item, FrameError), where
            assert item.reason in ("oversize", "cobs", "short", "version"), where
    return counts


def soak_bridge(program: Path, records: list[bytes]) -> dict[str, int]:
    """``records`` to the whole C bridge, 2 ms apart, before and in a session: no
    sanitizer report, and every frame it sends is one the host decodes."""
    session = CODEC.encode(Hello(1, DIGEST, 2)) + CODEC.encode(EStopReset(2))
    stream = bytearray(rec_w(b"", 35_000))
    for i, record in enumerate(records):
        stream += rec_w(session if i == len(records) // 2 else record, 2_000)
    stream += rec_w(b"\x00", 200_000)
    out = b"".join(bytes.fromhex(line[2:]) for line in run_c(program, bytes(stream)))
    got = FrameDecoder(CODEC).feed(out)
    bad = [m for m in got if isinstance(m, FrameError)]
    assert not bad, f"the host refused frames the C sent: {bad[:5]}"
    assert all(m.TYPE & 0x80 for m in got if not isinstance(m, FrameError))
    return {"records": len(records), "c_frames": len(got)}


# -- 2. a conversation --------------------------------------------------------------------------


@dataclass
class Step:
    """Bytes to both bridges at once, then ``ms`` of time; or a reset of both; or the
    hardware e-stop input pressed or released (no bytes: the C debounces it, 2 ms to
    trip and 50 to release, the reference bridge takes it at once)."""

    data: bytes
    reset: bool = False
    estop_input: bool | None = None
    ms: int = STEP_MS


def conversation(rng: random.Random, n: int) -> list[Step]:
    """A host's traffic, mostly well formed: sessions, retries, duplicates, old and
    wrapped seqs, every request with good and bad fields, resets, hostile bytes."""
    steps: list[Step] = [Step(CODEC.encode(Hello(1, DIGEST, 2))), Step(CODEC.encode(EStopReset(2)))]
    seq, pressed = 2, False
    for _ in range(n):
        pick = rng.random()
        if pick < 0.015:
            steps.append(Step(b"", reset=True))
            continue
        if pick < 0.025:
            pressed = not pressed
            steps.append(Step(b"", estop_input=pressed, ms=STEP_MS * (1 if pressed else 2)))
            continue
        jump = rng.random()
        if jump < 0.75:
            seq = (seq + 1) & 0xFFFF
        elif jump < 0.85:
            pass  # the same seq again (a retry, or another type with it)
        elif jump < 0.92:
            seq = (seq - rng.randrange(1, 40)) & 0xFFFF
        else:
            seq = (seq + rng.choice([0x7FFF, 0x8000, 0x8001, rng.randrange(65536)])) & 0xFFFF
        msg = host_message(rng, seq)
        if isinstance(msg, Hello) and rng.random() < 0.5:
            msg = Hello(seq, DIGEST, rng.choice([1, 2]))  # most hellos are accepted
        if isinstance(msg, EStop) and rng.random() < 0.5:
            msg = EStopReset(seq)  # a latch is mostly released soon
        frame = CODEC.encode(msg)
        if pick < 0.8:
            steps.append(Step(frame))
        elif pick < 0.95:
            steps.append(Step(mutate(rng, frame)))
        else:
            steps.append(Step(random_bytes(rng)))
    return steps


def normal(msg: Message) -> Message:
    """An answer without what two bridges may tell apart: firmware number, boot id."""
    if isinstance(msg, HelloReply):
        return replace(msg, firmware=0, boot_id=0)
    return msg


def state_view(msg: State) -> tuple[object, ...]:
    return (int(msg.flags), msg.ack_seq, msg.board_status, msg.fresh_mask)


def compare_bridges(program: Path, steps: list[Step]) -> dict[str, int]:
    """The C bridge and the reference bridge given the same steps: the same answers,
    the same last STATE of each step; the C's STATE carries the readings its boards
    gave. Returns counts."""
    from pirate_bt.pipes import load_network
    from pirate_bt.sim.bridge import SimBridge
    from pirate_bt.sim.model import PipeRobotModel

    rng = random.Random(len(steps))
    readings = [rng.randint(-32768, 32767) for _ in range(N_CHANNELS)]
    records = bytearray()
    for channel, raw in enumerate(readings):
        records += b"R" + struct.pack("<Bh", channel, raw)
    # boot at 0, boards polled; each step then starts 5 ms off the 10 ms STATE grid
    records += rec_w(b"", 35_000)
    for step in steps:
        if step.reset:
            records += rec_w(b"", 5_000) + b"T" + rec_w(b"", 5_000)
        else:
            if step.estop_input is not None:
                records += b"I" + bytes([step.estop_input])
            records += rec_w(step.data, step.ms * 1000)
    c_out = [bytes.fromhex(line[2:]) for line in run_c(program, bytes(records))]

    sim = SimBridge(PipeRobotModel(ROBOT, load_network("straight")))
    now_ms = 35
    sim.advance_to(now_ms / 1000)
    sim_out = [sim.read()]
    for step in steps:
        if step.reset:
            sim.advance_to((now_ms + 5) / 1000)
            sim.read()
            sim.reset()
            now_ms += 10
            sim.advance_to(now_ms / 1000)
            sim_out.append(b"")
            sim_out.append(sim.read())
            continue
        if step.estop_input is not None:
            sim.set_estop_input(step.estop_input)
        sim.receive(step.data)
        now_ms += step.ms
        sim.advance_to(now_ms / 1000)
        sim_out.append(sim.read())
    assert len(c_out) == len(sim_out)

    c_dec, sim_dec = FrameDecoder(FrameCodec.for_robot(ROBOT)), FrameDecoder(CODEC)
    counts = {"steps": len(steps), "answers": 0, "states": 0, "c_frames": 0}
    # the record of each output; None: a boot's first, whose bridge counter starts at 1
    after_boot = [True, True]  # C, reference: no frame of the bridge counter since boot
    records_of_steps: list[Step | None] = [None]
    for step in steps:
        records_of_steps += [step, None] if step.reset else [step]
    for i, (c_bytes, s_bytes, step) in enumerate(
        zip(c_out, sim_out, records_of_steps, strict=True)
    ):
        got_c, got_s = c_dec.feed(c_bytes), sim_dec.feed(s_bytes)
        where = f"output {i} ({'boot' if step is None else step.data.hex()})"
        bad = [m for m in got_c if isinstance(m, FrameError)]
        assert not bad, f"{where}: the host refused a frame the C sent: {bad}"
        counts["c_frames"] += len(got_c)
        if step is not None and step.reset:
            continue  # what was sent before the reset
        if step is None:
            after_boot = [True, True]
        # docs/protocol.md: the bridge counter is 1 for the first frame after boot
        for side, got in enumerate((got_c, got_s)):
            counted = [m for m in got if isinstance(m, State | BridgeHeartbeat)]
            if after_boot[side] and counted:
                assert isinstance(counted[0], State) and counted[0].seq == 1, f"{where}: {got}"
                after_boot[side] = False
        if step is None:
            continue
        answers_c = [normal(m) for m in got_c if not isinstance(m, State | BridgeHeartbeat)]
        answers_s = [normal(m) for m in got_s if not isinstance(m, State | BridgeHeartbeat)]
        assert answers_c == answers_s, f"{where}: C {answers_c} reference {answers_s}"
        counts["answers"] += len(answers_c)
        states_c = [m for m in got_c if isinstance(m, State)]
        states_s = [m for m in got_s if isinstance(m, State)]
        assert states_c and states_s, where
        assert state_view(states_c[-1]) == state_view(states_s[-1]), (
            f"{where}: last STATE C {states_c[-1]} reference {states_s[-1]}"
        )
        fresh = states_c[-1].fresh_mask
        for k, value in enumerate(states_c[-1].raw_values):
            assert not fresh >> k & 1 or value == readings[k], f"{where}: channel {k}"
        counts["states"] += len(states_c)
    return counts


# -- 3. frames the C encodes --------------------------------------------------------------------


def bridge_frame(rng: random.Random) -> tuple[int, int, int, bytes, bool]:
    """A frame a bridge sends: ``(type, seq, arg, payload, canonical)``. Canonical: a
    bridge type in the form the codec writes (arg 0 where it means nothing, no bits
    past the layout's channels and boards); else any type, arg and length."""
    seq = rng.randrange(65536)
    kind = rng.choice([0x81, 0x82, 0x82, 0x83, 0x84, 0x85, 0x86, -1])
    if kind == 0x81:
        payload = struct.pack(
            "<IBBHHBHB",
            DIGEST,
            N_CHANNELS,
            N_MOTORS,
            250,
            rng.randrange(65536),
            rng.choice([1, 2]),
            rng.randrange(65536),
            rng.randrange(256),
        )
        return kind, seq, rng.randrange(32), payload, True
    if kind == 0x82:
        msg = State(
            seq,
            BridgeFlags(rng.randrange(32)),
            rng.randrange(65536),
            rng.randrange(1 << N_CHANNELS),
            tuple(rng.randrange(16) for _ in BOARDS),
            tuple(rng.randint(-32768, 32767) for _ in range(N_CHANNELS)),
        )
        arg, payload = CODEC.encode_payload(msg)
        return kind, seq, arg, payload, True
    if kind in (0x83, 0x84):
        code = rng.choice([0, 1, 2]) if kind == 0x83 else rng.randrange(1, 11)
        return kind, seq, 0, bytes([rng.randrange(1, 8), code]), True
    if kind == 0x85:
        payload = struct.pack("<5I", *(rng.randrange(1 << 32) for _ in range(5)))
        payload += b"".join(
            struct.pack("<BIII", b, *(rng.randrange(1 << 32) for _ in range(3))) for b in BOARDS
        )
        return kind, seq, 0, payload, True
    if kind == 0x86:
        return kind, seq, rng.randrange(32), b"", True
    n = rng.choice([0, 2, 14, 247, rng.randrange(248)])
    payload = bytes(rng.randrange(256) for _ in range(n))
    return rng.randrange(256), seq, rng.randrange(256), payload, False


def compare_encoders(
    program: Path, frames: list[tuple[int, int, int, bytes, bool]]
) -> dict[str, int]:
    """``frame_encode`` of each frame against the Python codec's bytes and the host's
    decoding of the C's. Returns counts."""
    lines = run_c(program, b"".join(rec_e(*f[:4]) for f in frames))
    assert len(lines) == len(frames)
    decoder = FrameDecoder(CODEC)
    counts = {"frames": len(frames), "messages": 0}
    for (kind, seq, arg, payload, canonical), line in zip(frames, lines, strict=True):
        c_wire = bytes.fromhex(line[2:])
        where = f"{kind:#04x} seq {seq} arg {arg} payload {payload.hex()}: C {c_wire.hex()}"
        assert c_wire.count(0) == 1 and c_wire.endswith(b"\x00"), where
        assert c_wire == wire(kind, seq, arg, payload), where  # the Python codec's bytes
        assert fields_of(parse_raw(body_of(c_wire))) == (kind, seq, arg, payload), where
        (got,) = decoder.feed(c_wire)
        if isinstance(got, FrameError):
            assert not canonical, f"{where}: the host refused it: {got!r}"
            continue
        counts["messages"] += 1
        assert kind == got.TYPE and got.seq == seq, where
        if canonical:
            assert CODEC.encode(got) == c_wire, f"{where}: decoded as {got!r}"
    return counts


# -- the tests ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def probe(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    if shutil.which("cc") is None or shutil.which("make") is None:
        pytest.skip("no host C compiler (cc) or make: the bridge's C cannot be built")
    runtime = subprocess.run(
        ["cc", "-print-file-name=libasan.so"], capture_output=True, text=True, check=False
    ).stdout.strip()
    if not runtime or not Path(runtime).exists():
        pytest.skip("the compiler has no AddressSanitizer runtime (libasan.so)")
    yield build_probe(tmp_path_factory.mktemp("link-probe"))


def test_the_c_receiver_and_the_python_decoders_take_the_same_frames(probe: Path) -> None:
    """3000 records of good, mutated and random host bytes: the C and Python accept the
    same frames with the same fields and drop the same ones for the same kind of fault;
    the whole C bridge takes them too, and the host decodes all it sends back."""
    records = hostile_stream(random.Random(13), 3000)
    counts = compare_receivers(probe, records)
    assert counts["K"] > 800 and counts["C"] > 150 and counts["B"] > 1000, counts
    assert soak_bridge(probe, records)["c_frames"] > 1000


def test_the_c_bridge_answers_a_conversation_as_the_reference_bridge(probe: Path) -> None:
    """600 steps of sessions, requests, duplicates, resets and hostile bytes: the same
    answers and STATE from both bridges, and the host decodes every frame the C sent."""
    counts = compare_bridges(probe, conversation(random.Random(1013), 600))
    assert counts["answers"] > 400, counts


def test_frames_the_c_encodes_are_the_bytes_and_fields_of_the_python_codec(probe: Path) -> None:
    """1500 bridge frames, of every bridge type and of any type and length."""
    rng = random.Random(2013)
    counts = compare_encoders(probe, [bridge_frame(rng) for _ in range(1500)])
    assert counts["messages"] > 1000, counts


def run_probe(build: Path, records: int, steps: int, encoded: int, seed: int) -> None:
    """The long run (not a test): ``python -c 'import sys; sys.path.insert(0, "tests");
    import test_codec_differential13 as t; t.run_probe(Path("/tmp/p"), 40000, 5000,
    20000, 1)'``."""
    program = build_probe(build)
    rng = random.Random(seed)
    stream = hostile_stream(rng, records)
    print("receivers", compare_receivers(program, stream))
    print("bridge soak", soak_bridge(program, stream))
    print("bridges", compare_bridges(program, conversation(rng, steps)))
    print("encoders", compare_encoders(program, [bridge_frame(rng) for _ in range(encoded)]))
