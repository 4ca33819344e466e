"""The board-bus differential test's inputs: what the master (or noise) puts on a
board's line, the boards' sensor inputs, and how a line is cut into reads
(``tests/test_board_bus_differential13.py``, split from it along that seam)."""

from __future__ import annotations

import itertools
import random
import struct

from board_bus_support import (
    BOARD_INPUTS,
    BOARDS,
    BODY_MAX,
    EXCHANGE,
    KEEP,
    LAYOUT,
    REPLY,
    ROBOT,
    STOP,
    cobs_decode,
    cobs_encode,
    crc16_xmodem,
    doc_request,
    wire,
)

from pirate_bt.sim.board_vectors import pico_inputs

WIRE_MAX = 34  # the longest legal frame before its delimiter (33) and one more
Line = list[tuple[int, bool]]  # (byte, flagged by the USART)


# -- the boards' inputs ---------------------------------------------------------------------


def board_channels(board: int, rng: random.Random) -> tuple[list[int], dict[str, list[int]]]:
    """Channels the reference board can read exactly, and the inputs that give them."""
    if board in BOARD_INPUTS:
        inputs, channels = BOARD_INPUTS[board]
        return channels, inputs
    specs = [c for c in ROBOT.state_channels() if c.board == board]
    options = []
    for spec in specs:
        lo, hi = spec.conversion.raw
        adc = lo + (rng.randrange(1024) * (hi - lo + 1)) // 1024
        options.append(dict.fromkeys([adc, lo, spec.conversion.zero_raw, 0]))
    for guess in itertools.product(*options):
        try:
            return list(guess), pico_inputs(ROBOT, board, list(guess))
        except ValueError:
            continue
    raise AssertionError(f"board {board}: no channels the reference board reads")


# -- what the master (or noise) puts on a board's line ---------------------------------------


def _raw_choices(ranges: dict[int, tuple[int, int]], mode: int, rng: random.Random) -> int:
    lo, hi = ranges.get(mode, (-300, 300))
    return rng.choice(
        [0, lo, hi, lo - 1, hi + 1, rng.randint(lo, hi), rng.randint(-32768, 32767), -32768, 32767]
    )


def setpoints(rng: random.Random, board: int, count: int | None = None) -> list[tuple[int, int]]:
    motors = LAYOUT[board].motors if board in LAYOUT else []
    n = len(motors) if count is None else count
    out = []
    for k in range(n):
        ranges = motors[k].ranges if k < len(motors) else {}
        mode = rng.choice([0, 1, 2, 3, 0, 1, 2, 3, KEEP, KEEP, rng.randrange(4, 255)])
        out.append((mode, _raw_choices(ranges, mode, rng)))
    return out


def frame_body(addr: int, cmd: int, sp: list[tuple[int, int]]) -> bytes:
    return bytes([addr, cmd]) + b"".join(struct.pack("<Bh", m, r) for m, r in sp)


def chunk(rng: random.Random, board: int) -> tuple[str, bytes]:
    """One piece of line: its kind and its bytes."""
    n = len(LAYOUT[board].motors)
    good = doc_request(board, rng.choice([EXCHANGE, EXCHANGE, STOP]), setpoints(rng, board))
    kind = rng.choice(
        ["exchange"] * 6
        + ["stop"] * 2
        + [
            "bit_flip",
            "truncated",
            "truncated_runs_on",
            "wrong_crc",
            "wrong_address",
            "broadcast",
            "oversize_body",
            "oversize_line",
            "zero_bytes",
            "zero_inside",
            "cobs_past_end",
            "random",
            "random_no_zero",
            "crc_valid_nonsense",
            "wrong_length",
            "stop_to_every_board",
            "leading_zeros",
            "noise_then_frame",
            "two_exchanges",
            "exchange_then_stop",
            "trailing_bytes",
        ]
    )
    if kind == "exchange":
        return kind, doc_request(board, EXCHANGE, setpoints(rng, board))
    if kind == "stop":
        return kind, doc_request(board, STOP, setpoints(rng, board))
    if kind == "bit_flip":
        frame = bytearray(good)
        for _ in range(rng.choice([1, 1, 2])):
            frame[rng.randrange(len(frame))] ^= 1 << rng.randrange(8)
        return kind, bytes(frame)
    if kind == "truncated":
        return kind, good[: rng.randrange(0, len(good) - 1)] + b"\x00"
    if kind == "truncated_runs_on":  # no delimiter: joins whatever comes next
        return kind, good[: rng.randrange(1, len(good) - 1)]
    if kind == "wrong_crc":
        body = frame_body(board, rng.choice([EXCHANGE, STOP]), setpoints(rng, board))
        crc = crc16_xmodem(body) ^ rng.randrange(1, 0x10000)
        return kind, cobs_encode(body + crc.to_bytes(2, "little")) + b"\x00"
    if kind == "wrong_address":
        addr = rng.choice([b for b in BOARDS if b != board] + [1, 19, 29, 0x7F, 0x80 | board])
        count = len(LAYOUT[addr].motors) if addr in LAYOUT and rng.random() < 0.7 else n
        return kind, doc_request(addr, rng.choice([EXCHANGE, STOP]), setpoints(rng, addr, count))
    if kind == "broadcast":  # the page has no broadcast address: 0 and 0xFF are no board
        addr = rng.choice([0x00, 0xFF])
        return kind, doc_request(addr, rng.choice([EXCHANGE, STOP]), setpoints(rng, board))
    if kind == "oversize_body":  # CRC-valid, to this board, 33 bytes and more of body
        body = bytes([board, rng.choice([EXCHANGE, STOP])]) + rng.randbytes(
            rng.randint(BODY_MAX - 3, BODY_MAX + 20)
        )
        return kind, wire(body)
    if kind == "oversize_line":  # a good frame behind more non-zero bytes than any frame
        junk = bytes(rng.randrange(1, 256) for _ in range(rng.randint(WIRE_MAX - 1, 120)))
        return kind, junk + good
    if kind == "zero_bytes":
        return kind, b"\x00" * rng.randint(1, 4)
    if kind == "zero_inside":  # a 0x00 within a frame: two bad frames
        frame = bytearray(good)
        frame.insert(rng.randrange(1, len(frame) - 1), 0)
        return kind, bytes(frame)
    if kind == "cobs_past_end":
        frame = bytearray(good[:-1])
        i, codes = 0, []
        while i < len(frame):
            codes.append(i)
            i += frame[i]
        at = rng.choice(codes)
        frame[at] = min(255, len(frame) - at + rng.randint(1, 30))
        return kind, bytes(frame) + b"\x00"
    if kind == "random":
        return kind, rng.randbytes(rng.randint(1, 60))
    if kind == "random_no_zero":
        return kind, bytes(rng.randrange(1, 256) for _ in range(rng.randint(1, 40))) + b"\x00"
    if kind == "crc_valid_nonsense":
        addr = rng.choice([board, board, rng.randrange(256)])
        return kind, wire(bytes([addr, rng.randrange(256)]) + rng.randbytes(rng.randint(0, 30)))
    if kind == "wrong_length":
        count = max(0, n + rng.choice([-2, -1, 1, 2]))
        return kind, doc_request(board, rng.choice([EXCHANGE, STOP]), setpoints(rng, board, count))
    if kind == "stop_to_every_board":  # as the bridge sends them, back to back
        return kind, b"".join(doc_request(b, STOP, setpoints(rng, b)) for b in BOARDS)
    if kind == "two_exchanges":  # a second request before the first was answered
        return kind, good + doc_request(board, EXCHANGE, setpoints(rng, board))
    if kind == "exchange_then_stop":
        return kind, doc_request(board, EXCHANGE, setpoints(rng, board)) + doc_request(
            board, STOP, setpoints(rng, board)
        )
    if kind == "trailing_bytes":  # a good body and CRC, then more bytes in the frame
        body = cobs_decode(good[:-1]) or b""
        return kind, cobs_encode(body + rng.randbytes(rng.randint(1, 4))) + b"\x00"
    if kind == "leading_zeros":
        return kind, b"\x00" * rng.randint(1, 3) + good
    # noise without a delimiter, then a frame: one bad frame
    return kind, bytes(rng.randrange(1, 256) for _ in range(rng.randint(1, 8))) + good


def cuts(rng: random.Random, data: bytes) -> list[bytes]:
    """The bytes as the receiver reads them: in one piece, or split anywhere."""
    if len(data) < 2 or rng.random() < 0.5:
        return [data]
    at = sorted(rng.sample(range(1, len(data)), min(len(data) - 1, rng.randint(1, 3))))
    return [data[i:j] for i, j in zip([0, *at], [*at, len(data)], strict=True)]


def frames_of(data: bytes) -> list[bytes]:
    return [f + b"\x00" for f in data.split(b"\x00")[:-1] if f]


# -- what a board's reply may become on the line -------------------------------------------


def reply_variants(rng: random.Random, board: int, reply: bytes) -> list[tuple[str, Line]]:
    """A board's reply (wire bytes) and what the line may make of it."""
    n = LAYOUT[board].n_channels
    body = cobs_decode(reply[:-1]) or b""
    plain = [(b, False) for b in reply]
    out: list[tuple[str, Line]] = [("as_sent", plain)]

    def rewired(new_body: bytes) -> Line:
        return [(b, False) for b in wire(new_body)]

    # good replies with every status byte and any channel values
    status = rng.randrange(256)
    out.append(("status_byte", rewired(bytes([board, REPLY, status]) + body[3:-2])))
    values = [rng.choice([-32768, 32767, 0, -1, rng.randint(-32768, 32767)]) for _ in range(n)]
    out.append(
        ("channels", rewired(bytes([board, REPLY, body[2]]) + struct.pack(f"<{n}h", *values)))
    )
    frame = bytearray(reply[:-1])
    i = rng.randrange(len(frame))
    flipped = bytearray(frame)
    flipped[i] ^= 1 << rng.randrange(8)
    out.append(("bit_flip", [(b, False) for b in flipped] + [(0, False)]))
    out.append(
        ("truncated", [(b, False) for b in frame[: rng.randrange(len(frame))]] + [(0, False)])
    )
    out.append(("no_delimiter", [(b, False) for b in frame]))
    extra = bytearray(frame)
    extra.insert(i, rng.randrange(1, 256))
    out.append(("byte_inserted", [(b, False) for b in extra] + [(0, False)]))
    out.append(("byte_lost", [(b, False) for j, b in enumerate(frame) if j != i] + [(0, False)]))
    crc = (crc16_xmodem(body[:-2]) ^ rng.randrange(1, 0x10000)).to_bytes(2, "little")
    out.append(("wrong_crc", [(b, False) for b in cobs_encode(body[:-2] + crc)] + [(0, False)]))
    other = rng.choice([b for b in BOARDS if b != board] + [0, 0xFF])
    out.append(("wrong_address", rewired(bytes([other]) + body[1:-2])))
    cmd = rng.choice([0x01, 0x02, 0x80, 0x82, 0xC1, 0x00, 0xFF])
    out.append(("wrong_cmd", rewired(bytes([board, cmd]) + body[2:-2])))
    more = rng.choice([-2, -1, 1, 2])
    payload = body[3:-2] + rng.randbytes(2 * max(more, 0))
    payload = payload[: len(payload) + 2 * min(more, 0)]
    out.append(("wrong_length", rewired(bytes([board, REPLY, body[2]]) + payload)))
    out.append(("trailing_bytes", [(b, False) for b in cobs_encode(body + b"\x01")] + [(0, False)]))
    out.append(("odd_length", rewired(body[:-2] + b"\x07")))
    out.append(("leading_zeros", [(0, False)] * rng.randint(1, 3) + plain))
    out.append(("flagged_leading_zero", [(0, True), *plain]))
    j = rng.randrange(len(reply))
    out.append(("flagged_byte", [(b, k == j) for k, b in enumerate(reply)]))
    out.append(("twice", plain + plain))
    out.append(("noise_before", [(rng.randrange(1, 256), False), *plain]))
    junk = [(rng.randrange(1, 256), False) for _ in range(rng.randint(WIRE_MAX - 1, 90))]
    out.append(("oversize", [*junk, (0, False), *plain]))
    past = bytearray(frame)
    past[0] = min(255, len(past) + rng.randint(1, 20))
    out.append(("cobs_past_end", [(b, False) for b in past] + [(0, False)]))
    out.append(("random", [(b, False) for b in rng.randbytes(rng.randint(1, 50))]))
    return out
