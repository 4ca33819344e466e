"""Differential tests of the board bus, as an outside implementer would run them.

1. The PICO firmware's request parser and reply builder (``firmware/pico/bus.c``, its
   host build under AddressSanitizer and UBSan) against the Python boards
   (:class:`pirate_bt.sim.boardbus.BoardBus`) and the page's board
   (:class:`board_bus_support.DocBoard`): the same bytes (good ``EXCHANGE`` and
   ``STOP`` frames for every board and every mode code, and mutated ones: bit flips,
   truncations, wrong CRCs, wrong and "broadcast" addresses, oversize frames, zero
   bytes, a COBS code pointing past the end, random bytes, frames split across
   reads), delivered at the same instants, must be answered with the same reply
   bytes, leave every motor with the same setpoint and the same own stop.
2. The bridge's reply decoding (``firmware/piratebay/board_bus.c``, the same host
   build) against the page's decoding of the same replies (``doc_take_reply`` and the
   receiving rules of docs/board-bus.md): the PICO's own replies and mutations of them
   must be taken with the same status and channels, refused, or not yet complete,
   alike; and through the whole poller (``poller.c``) the status nibble, the fresh
   bits, the channels and the counters must be what the page says a reply means.

Where the two may legitimately differ, the page says so and the comparison here
allows exactly that: a reply's timing (the PICO answers after its 150 µs turnaround,
the Python boards at once), the instant of a board's own stop within the tick after
its 100 ms of silence, and a second request heard before the first was answered
(a master never sends one; the PICO answers only the last).

The C runs in a child process with the sanitizer runtime preloaded; the parent only
checks its report. ``python tests/test_board_bus_differential13.py N`` runs the same
comparisons with N times the committed test's frames (the big probe).
"""

from __future__ import annotations

import ctypes
import json
import os
import random
import shutil
import struct
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from board_bus_diff_inputs import (
    Line,
    board_channels,
    chunk,
    cuts,
    frame_body,
    frames_of,
    reply_variants,
    setpoints,
)
from board_bus_support import (
    ASAN,
    BOARDS,
    EXCHANGE,
    FAULT,
    KEEP,
    LAYOUT,
    MOTORS_OFF,
    OWN_STOP,
    ROBOT,
    STOP,
    DocBoard,
    Pico,
    Splitter,
    _layout_header,
    _make,
    _wait,
    cobs_decode,
    doc_request,
    doc_take_reply,
)

from pirate_bt.pipes import load_network
from pirate_bt.sim.boardbus import BoardBus
from pirate_bt.sim.model import PipeRobotModel

ONLINE, B_FAULT, TIMEOUT, B_MOTORS_OFF = 1, 2, 4, 8
STALE = 0x08  # a reply's status bit 3


def sensor_channels(board: int) -> list[int]:
    """The board's sensor channels: its reply's first, before its motors' feedback."""
    mine = [c.index for c in ROBOT.state_channels() if c.board == board]
    motors = ROBOT.board(board).motors
    feedback = sum(
        (m.feedback.velocity is not None) + (m.feedback.current is not None) for m in motors
    )
    return mine[: len(mine) - feedback]


BUS_OK, BUS_TIMEOUT, BUS_BAD = 1, 2, 3
SILENT_US = 100_000
# the instant of a board's own stop may lie anywhere in here after the master's last
# good frame to it (the page: "within 100 ms + 1 ms"; the PICO counts whole ms ticks)
UNSURE_US = (99_000, 102_500)


# -- 1. the PICO against the Python boards and the page's board ------------------------------


_LIBRARIES: dict[tuple[Path, int], ctypes.CDLL] = {}


class PicoBoard(Pico):
    """The PICO's host build as board `board`, booted now, its clock from 0 at its boot.

    One copy of the library per board id, booted again for each run (a process can
    load only so many copies of a library built with the sanitizers)."""

    def __init__(  # its own library copies, not Pico's
        self, library: Path, workdir: Path, board: int, inputs: dict[str, list[int]]
    ) -> None:
        key = (library, board)
        if key not in _LIBRARIES:
            copy = workdir / f"pico-d13-{board}.so"
            shutil.copy(library, copy)
            _LIBRARIES[key] = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        self.lib = _LIBRARIES[key]
        self.lib.bus_own_stop.restype = ctypes.c_bool
        self.lib.pk_now_us.restype = ctypes.c_uint64
        self.lib.pk_run_us(ctypes.c_uint32(1000 - self.lib.pk_now_us() % 1000))
        self.base_us = int(self.lib.pk_now_us())  # a whole millisecond, as at a power-on
        self.now_us = 0
        self.lib.pk_boot(board, 0)
        self.lib.pk_imu(*inputs["imu"])
        for i, value in enumerate(inputs["adc"]):
            self.lib.pk_adc(i, value)

    # run_to, write, read and motors: board_bus_support.Pico's (the same host build)


LAYOUT_SLOTS = {
    b: [s.slot for s in ROBOT.setpoint_slots() if s.board == b] for b in ROBOT.board_ids()
}


def compare_boards(
    pico_lib: Path, workdir: Path, seed: int, steps: int, replies: list[tuple[int, bytes]]
) -> Counter[str]:
    """Every board in turn: `steps` pieces of line each, the PICO, the Python boards and
    the page's board side by side. Raises AssertionError on the first discrepancy. The
    PICO's replies go to `replies` (a sample), for the bridge."""
    counts: Counter[str] = Counter()
    for board in BOARDS:
        rng = random.Random(seed * 1000 + board)
        channels, inputs = board_channels(board, rng)
        n = len(LAYOUT[board].motors)
        pico = PicoBoard(pico_lib, workdir, board, inputs)
        bus = BoardBus(PipeRobotModel(ROBOT, load_network("straight")))
        bus.set_readings(board, channels)
        python = Splitter(bus, board)
        doc = DocBoard(LAYOUT[board], channels)
        t_us = 5000
        pico.run_to(t_us)
        was_own = False
        for step in range(steps):
            gap = rng.choice([1000] * 8 + [400, 600, 2500, rng.randint(20_000, 140_000)])
            t_us += gap
            silence = t_us - round(doc.heard_s * 1e6)
            if UNSURE_US[0] <= silence <= UNSURE_US[1] and not doc.own_stop:
                t_us += UNSURE_US[1] - silence + 500
            kind, data = chunk(rng, board)
            counts[f"kind {kind}"] += 1
            counts["delimiters"] += data.count(0)
            where = f"seed {seed} board {board} step {step} ({kind}): {data.hex()}"
            pieces = cuts(rng, data)
            counts["split" if len(pieces) > 1 else "whole"] += 1
            doc.advance(t_us / 1e6)
            want_doc = b""
            at = t_us
            python_out = b""
            for piece in pieces:
                pico.run_to(at)
                pico.write(piece)
                python_out += python.receive(at / 1e6, piece)
                want_doc += doc.receive(piece)
                at += rng.choice([10, 20, 50])
            pico.run_to(at + 400)
            got = pico.read()
            mine = [f for f in frames_of(data)]
            if python_out != got:
                # a second request before the first was answered: the PICO answers the
                # last one only (the page allows it, the master never does it)
                answers = frames_of(python_out)
                assert len(answers) > 1 and got == answers[-1], (where, python_out, got)
                counts["requests answered as one"] += 1
            assert want_doc == python_out, (where, want_doc, python_out)
            counts["replies"] += len(frames_of(got))
            if got and rng.random() < 0.2:
                replies.append((board, frames_of(got)[-1]))
            counts["frames to this board"] += sum(
                1 for f in mine if (cobs_decode(f[:-1]) or b"\x00")[0] == board
            )
            motors = pico.motors(n)
            assert motors == python.motors() == doc.state, (where, motors, python.motors())
            own = bool(pico.lib.bus_own_stop())
            counts["own stops"] += own and not was_own
            was_own = own
            assert own == (board in bus.own_stop) == doc.own_stop, (where, own)
            counts["own stop steps" if own else "running steps"] += 1
            if own:
                # the stop reaches the H-bridges: every motor the stop set is braked
                for k, motor in enumerate(motors):
                    value = (ctypes.c_int16 * 2)()
                    pico.lib.pk_motor(LAYOUT_SLOTS[board][k], value)
                    if motor == (0, 0) or motor == (3, 0):
                        assert value[0] == 1, (where, k, list(value))
        counts["boards"] += 1
    return counts


# -- 2. the bridge's decoding of replies against the page's -----------------------------------


class BusReply(ctypes.Structure):
    _fields_ = [("status", ctypes.c_uint8), ("readings", ctypes.c_int16 * 8)]


class Setpoint(ctypes.Structure):
    _fields_ = [("mode", ctypes.c_uint8), ("raw", ctypes.c_int16)]


def page_reply(board: int, line: Line) -> tuple[str, Any]:
    """The page's master: the first frame heard after the request (empty ones skipped,
    a flagged lone delimiter too) is the reply; a byte flagged in it makes it bad."""
    raw, damaged = bytearray(), False
    for byte, flagged in line:
        if flagged and byte == 0 and not raw and not damaged:
            continue
        damaged |= flagged
        if byte:
            raw.append(byte)
            continue
        if not raw and not damaged:
            continue
        if damaged:
            return "bad", None
        taken = doc_take_reply(board, bytes(raw))
        return ("bad", None) if taken is None else ("ok", taken)
    return "none", None


class BridgeBus:
    """The bridge's board_bus.c in its host build, called directly: one exchange with
    one board, the reply's bytes on the line, what board_bus_poll() makes of them."""

    def __init__(self, library: Path, workdir: Path) -> None:
        copy = workdir / f"bridge-d13-{id(self)}.so"
        shutil.copy(library, copy)
        self.lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        for index in range(len(BOARDS)):
            self.lib.fw_board(index, 0, 0)  # the host build's own boards keep quiet
        self.lib.fw_boot()
        self.lib.layout_board.restype = ctypes.c_void_p
        self.lib.layout_board.argtypes = [ctypes.c_uint8]
        self.lib.board_bus_exchange.argtypes = [ctypes.c_void_p, ctypes.POINTER(Setpoint)]
        self.lib.board_bus_poll.argtypes = [ctypes.POINTER(BusReply)]
        self.log = ctypes.create_string_buffer(1 << 16)

    def exchange(self, board: int, sp: list[tuple[int, int]], line: Line) -> tuple[str, Any]:
        array = (Setpoint * max(1, len(sp)))(*[Setpoint(m, r) for m, r in sp])
        self.lib.board_bus_exchange(self.lib.layout_board(BOARDS.index(board)), array)
        n = self.lib.fw_bus_log(self.log, len(self.log))
        sent = self.log.raw[1 : n - 2] if n else b""
        assert self.log.raw[0] == n - 1 and sent == frame_body(board, EXCHANGE, sp), (sent, sp)
        run = bytearray()
        for byte, flagged in line:
            if flagged:
                self.lib.fw_bus_inject(bytes(run), len(run))
                run.clear()
                self.lib.fw_bus_inject_damaged(byte)
            else:
                run.append(byte)
        self.lib.fw_bus_inject(bytes(run), len(run))
        reply = BusReply()
        result = self.lib.board_bus_poll(ctypes.byref(reply))
        if result == BUS_OK:
            k = LAYOUT[board].n_channels
            return "ok", (reply.status, list(reply.readings[:k]))
        return {BUS_BAD: "bad", 0: "none"}.get(result, f"result {result}"), None


_MASTERS: dict[Path, BridgeBus] = {}


def compare_decoding(
    bridge_lib: Path, workdir: Path, replies: list[tuple[int, bytes]], seed: int
) -> Counter[str]:
    counts: Counter[str] = Counter()
    rng = random.Random(seed)
    if bridge_lib not in _MASTERS:
        _MASTERS[bridge_lib] = BridgeBus(bridge_lib, workdir)
    master = _MASTERS[bridge_lib]
    for board, reply in replies:
        for name, line in reply_variants(rng, board, reply):
            sp = [(m, r) for m, r in setpoints(rng, board)]
            sp = [(m if m in (0, 1, 2, 3, KEEP) else KEEP, r) for m, r in sp]
            want = page_reply(board, line)
            got = master.exchange(board, sp, line)
            assert got == want, (board, name, bytes(b for b, _ in line).hex(), got, want)
            counts[f"decoded {want[0]}"] += 1
            counts[f"variant {name}"] += 1
            if want[0] == "ok":
                for bit, name_ in (
                    (FAULT, "FAULT"),
                    (MOTORS_OFF, "MOTORS_OFF"),
                    (OWN_STOP, "OWN_STOP"),
                    (STALE, "STALE"),
                ):
                    counts[f"ok with {name_}"] += bool(want[1][0] & bit)
                counts["ok with other status bits"] += bool(want[1][0] & 0xF0)
    return counts


# -- 2b. the poller: status nibble, fresh bits, channels, counters -----------------------------


def compare_poller(
    bridge_lib: Path, workdir: Path, replies: list[tuple[int, bytes]], seed: int, trials: int
) -> Counter[str]:
    """A board answers every poll with one variant of a PICO reply; after two periods the
    bridge's STATE and COUNTERS must say what the page says that reply means."""
    from test_firmware_core import COUNTERS_REQUEST, STATE, Bridge, frame

    counts: Counter[str] = Counter()
    rng = random.Random(seed)
    copy = workdir / f"poller-d13-{seed}.so"
    shutil.copy(bridge_lib, copy)
    host = Bridge(copy, ROBOT)  # the host build's boards answer: every board ONLINE
    host.run(25)
    host.read()
    before = _counters(host, COUNTERS_REQUEST, frame, 1)
    seq = 2
    for trial in range(trials):
        board, reply = rng.choice(replies)
        name, line = rng.choice(reply_variants(rng, board, reply))
        if any(flagged for _, flagged in line) or len(line) > 64:
            continue  # a fixed reply is plain bytes of at most 64
        index = BOARDS.index(board)
        data = bytes(b for b, _ in line)
        want, taken = page_reply(board, line)
        host.lib.fw_board_reply(index, data, len(data))
        host.bus()
        host.run(20)
        states = [f for f in host.read() if f.kind == STATE]
        _, fresh, _, status, values = host.state(states[-1])
        host.lib.fw_board_reply(index, b"", 0)
        mine = [c.index for c in ROBOT.state_channels() if c.board == board]
        nibble = host.lib.poller_board_status(index)  # the poller's, from the reply alone
        # STATE's nibble: the poller's, MOTORS_OFF also when the bridge itself has not
        # commanded a motor of the board (protocol.c): here, no session ever did
        assert status[index] == nibble | B_MOTORS_OFF, (status[index], nibble)
        where = (trial, board, name, data.hex(), want, taken, nibble)
        seq += 1
        after = _counters(host, COUNTERS_REQUEST, frame, seq)
        delta = [a - b for a, b in zip(after[board], before[board], strict=True)]
        before = after
        stops = {body[0] for body in host.bus() if body[1] == STOP}
        if want == "ok":
            status_byte, channels = taken
            expect = ONLINE
            expect |= B_FAULT if status_byte & FAULT else 0
            expect |= B_MOTORS_OFF if status_byte & MOTORS_OFF else 0
            assert nibble == expect, where
            # STALE (status bit 3): the board's sensors not fresh, its motors' feedback
            # fresh (docs/board-bus.md); without it every channel of the board is fresh
            stale = sensor_channels(board) if status_byte & STALE else []
            assert [fresh >> c & 1 for c in mine] == [c not in stale for c in mine], where
            assert [values[c] for c in mine] == channels, where
            assert delta == [0, 0, 0], (where, delta)
            # OWN_STOP: the whole robot stops, a STOP to every board
            assert (stops == set(BOARDS)) == bool(status_byte & OWN_STOP), (where, stops)
        else:
            assert nibble == TIMEOUT and not any(fresh >> c & 1 for c in mine), where
            timeouts, crc, retries = delta
            if want == "bad":
                assert timeouts == 0 and crc >= 2 and retries >= 1, (where, delta)
            else:
                assert crc == 0 and timeouts >= 2 and retries >= 1, (where, delta)
        counts[f"poller {want}"] += 1
        # the next trial starts from a clean period: the board answers again
        host.run(20)
        host.read()
        seq += 1
        before = _counters(host, COUNTERS_REQUEST, frame, seq)
    return counts


def _counters(host: Any, request: int, frame: Any, seq: int) -> dict[int, list[int]]:
    host.write(frame(request, seq))
    host.run(12)
    frames = host.read()
    got = [f for f in frames if f.seq == seq and f.kind != 0x82]
    assert len(got) == 1, (seq, frames)
    (answer,) = got
    out = {}
    for j, board in enumerate(BOARDS):
        part = answer.payload[20 + 13 * j : 33 + 13 * j]
        out[board] = list(struct.unpack("<BIII", part)[1:])
    return out


# -- the child: all of it, with the sanitizers' runtime preloaded -----------------------------


def own_stop_instants(pico_lib: Path, workdir: Path, seed: int, samples: int) -> Counter[str]:
    """When the PICO stops itself after the master's last good frame to it: the page
    says after 100 ms of silence, within 100 ms + 1 ms (the Python boards: the first
    instant past 100 ms). Measured to 10 µs, the frame at any point of a millisecond."""
    counts: Counter[str] = Counter()
    rng = random.Random(seed)
    board = 22
    _channels, inputs = board_channels(board, rng)
    pico = PicoBoard(pico_lib, workdir, board, inputs)
    t_us = 5000
    for _ in range(samples):
        t_us += 1000 + rng.randrange(0, 1000, 10)
        pico.run_to(t_us)
        pico.write(doc_request(board, STOP, [(KEEP, 0)] * len(LAYOUT[board].motors)))
        pico.run_to(t_us + 99_000)
        assert not pico.lib.bus_own_stop()
        while not pico.lib.bus_own_stop():
            pico.run_to(pico.now_us + 10)
        after = pico.now_us - t_us
        assert SILENT_US <= after <= SILENT_US + 1000, after
        counts["own stop instants"] += 1
        late = after - SILENT_US
        counts["own stop latest us"] = max(counts["own stop latest us"], late)
        counts["own stop earliest us"] = min(counts.get("own stop earliest us", 9999), late)
        t_us = pico.now_us
    return counts


def unknown_ids(pico_lib: Path, workdir: Path, seed: int) -> Counter[str]:
    """A PICO whose id is no board of the layout (the page: no broadcast address, no
    board for 0, 0xFF or any id outside the description) answers nothing and moves
    nothing, whatever it hears; the Python boards have no such board to answer."""
    counts: Counter[str] = Counter()
    rng = random.Random(seed)
    for board in (0, 1, 19, 29, 0x7F, 0xFF):
        pico = PicoBoard(pico_lib, workdir, board, {"adc": [0] * 4, "imu": [0] * 3})
        bus = BoardBus(PipeRobotModel(ROBOT, load_network("straight")))
        for step in range(40):
            data = doc_request(board, rng.choice([EXCHANGE, STOP]), setpoints(rng, 22))
            pico.run_to(5000 + 1000 * step)
            pico.write(data)
            pico.run_to(5400 + 1000 * step)
            assert pico.read() == b"" and bus.handle(step / 1000, data[:-1]) == b""
            assert pico.motors(2) == [None, None]
            counts["frames to no board"] += 1
    return counts


def child(pico_lib: Path, bridge_lib: Path, workdir: Path, scale: int) -> dict[str, int]:
    counts: Counter[str] = Counter()
    replies: list[tuple[int, bytes]] = []
    for seed in range(scale):
        counts += compare_boards(pico_lib, workdir, seed, 160, replies)
    counts += unknown_ids(pico_lib, workdir, scale)
    counts += own_stop_instants(pico_lib, workdir, scale, 10 * scale)
    # the bridge gets the PICO's own replies (every status they had), and their mutations
    counts["pico replies for the bridge"] = len(replies)
    for seed in range(scale):
        counts += compare_decoding(bridge_lib, workdir, replies, seed)
    counts += compare_poller(bridge_lib, workdir, replies, scale, 40 * scale)
    return dict(counts)


# -- the committed test ---------------------------------------------------------------------


def _runtime() -> str | None:
    if shutil.which("cc") is None or shutil.which("make") is None:
        return None
    path = subprocess.run(
        ["cc", "-print-file-name=libasan.so"], capture_output=True, text=True, check=False
    ).stdout.strip()
    return path if path and Path(path).exists() else None


def _build(build: Path) -> None:
    _layout_header(build)
    jobs = [_make(d, build, "HOST_OPT=-O1", f"HOST_SANITIZE={ASAN}") for d in ("pico", "piratebay")]
    for job in jobs:
        _wait(job)


def run_child(build: Path, workdir: Path, scale: int, runtime: str) -> dict[str, int]:
    done = subprocess.run(
        [
            sys.executable,
            __file__,
            "--child",
            str(build / "libpico_host.so"),
            str(build / "libpiratebay_host.so"),
            str(workdir),
            str(scale),
        ],
        capture_output=True,
        text=True,
        timeout=1800,
        check=False,
        env={
            **os.environ,
            "LD_PRELOAD": runtime,
            "ASAN_OPTIONS": "detect_leaks=0:abort_on_error=0:exitcode=99",
            "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1:exitcode=98",
        },
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert "runtime error" not in done.stderr and "Sanitizer" not in done.stderr
    counts: dict[str, int] = json.loads(done.stdout.strip().splitlines()[-1])
    return counts


def test_pico_python_and_bridge_agree_on_every_byte(tmp_path: Path) -> None:
    """The PICO and the Python boards answer 1440 pieces of line alike, the bridge and the
    page decode 1700 replies alike, the poller reports 40 replies as the page says, all
    under AddressSanitizer and UBSan."""
    runtime = _runtime()
    if runtime is None:
        pytest.skip(
            "no host C compiler (cc) and make, or no AddressSanitizer runtime (libasan.so): "
            "the firmwares' C cannot be built with -fsanitize=address,undefined"
        )
    build = tmp_path / "asan"
    build.mkdir()
    _build(build)
    counts = run_child(build, tmp_path, 1, runtime)
    assert counts["boards"] == len(BOARDS)
    assert counts["delimiters"] > 1500 and counts["replies"] > 400
    assert counts["own stops"] > 0 and counts["own stop steps"] > 50
    assert counts["decoded ok"] > 100 and counts["decoded bad"] > 100 and counts["decoded none"]
    assert counts["poller ok"] > 5 and counts["poller bad"] > 5


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        pico_arg, bridge_arg, work_arg, scale_arg = sys.argv[2:6]
        result = child(Path(pico_arg), Path(bridge_arg), Path(work_arg), int(scale_arg))
        print(json.dumps(result, sort_keys=True))
    else:  # the big probe: python tests/test_board_bus_differential13.py [SCALE]
        import tempfile

        found = _runtime()
        assert found, "the probe needs cc, make and libasan"
        with tempfile.TemporaryDirectory() as tmp:
            build_dir = Path(tmp) / "asan"
            build_dir.mkdir()
            _build(build_dir)
            scale_n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
            print(json.dumps(run_child(build_dir, Path(tmp), scale_n, found), indent=1))
