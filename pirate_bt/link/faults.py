"""Fault injection: a byte-link wrapper that drops, corrupts, duplicates, delays and reorders.

The 2018 bus lost messages now and then and nobody could reproduce it. Here a
test (or an operator rehearsing with the simulator) can ask for exactly that::

    spec = parse_fault_spec("drop=0.1,corrupt=0.02,dup=0.02,delay=5ms,reorder=0.01,seed=7")
    link = FaultyLink(transport, spec, clock)

or put the same spec in the port URL: ``loop://?faults=drop=0.1,dup=0.02&seed=7``
(see :func:`split_fault_url`). Faults act on whole frames (split at the 0x00
delimiter), in both directions unless ``direction`` says otherwise, with one
seeded :class:`random.Random`, so a failing run can be replayed exactly. A delay
holds a frame until the injected clock reaches its release time; with a
:class:`~pirate_bt.clock.SimClock` that is simulated time.
"""

from __future__ import annotations

import heapq
import itertools
import random
import urllib.parse
from dataclasses import dataclass

from pirate_bt.clock import Clock
from pirate_bt.errors import ArgumentTypeError, InputError, UnitError, shown
from pirate_bt.link.transport import ByteLink
from pirate_bt.units import parse_quantity

__all__ = ["MAX_SPEC_TEXT", "FaultSpec", "FaultyLink", "parse_fault_spec", "split_fault_url"]

_PROBABILITIES = ("drop", "corrupt", "dup", "reorder")


@dataclass(frozen=True, slots=True)
class FaultSpec:
    """What to inject; probabilities are per frame.

    Attributes:
        drop: Probability that a frame vanishes.
        corrupt: Probability that one byte of a frame is changed.
        dup: Probability that a frame is delivered twice.
        delay_s: Every frame is held this long (plus up to ``jitter_s``).
        jitter_s: Extra random delay, uniform in [0, jitter_s].
        reorder: Probability that a frame is held back behind the next one.
        seed: Seed of the random generator.
        direction: ``both``, ``tx`` (host -> bridge) or ``rx`` (bridge -> host).
    """

    drop: float = 0.0
    corrupt: float = 0.0
    dup: float = 0.0
    delay_s: float = 0.0
    jitter_s: float = 0.0
    reorder: float = 0.0
    seed: int = 0
    direction: str = "both"

    @property
    def active(self) -> bool:
        """Any fault is switched on."""
        return (
            any(getattr(self, k) > 0 for k in _PROBABILITIES)
            or self.delay_s > 0
            or (self.jitter_s > 0)
        )


MAX_SPEC_TEXT = 10_000
"""The longest link fault spec (every key once is under 200 characters)."""


def parse_fault_spec(text: str, *, option: str = "faults") -> FaultSpec:
    """Parse ``"drop=0.1,corrupt=0.02,dup=0.02,delay=5ms,reorder=0.01,seed=3"``.

    Keys: ``drop``, ``corrupt``, ``dup``, ``reorder`` (probabilities 0..1),
    ``delay`` and ``jitter`` (durations with a unit, e.g. ``5ms``), ``seed`` (int),
    ``direction`` (``both``/``tx``/``rx``). An empty string means no faults.

    Args:
        text: The spec.
        option: Where the spec came from, starting every message (``faults``: the
            API's ``faults=``, the command line's ``--faults`` and a port URL's
            ``?faults=``; ``""``: none).

    Returns:
        The parsed spec.

    Raises:
        InputError: unknown key, malformed item, a value out of range, or a spec
            longer than :data:`MAX_SPEC_TEXT` (an ``ArgumentTypeError``: not text).
    """
    prefix = f"{option}: " if option else ""
    if not isinstance(text, str):
        raise ArgumentTypeError(f"{prefix}a link fault spec is text, not {shown(text)}")
    if len(text) > MAX_SPEC_TEXT:
        raise InputError(
            f"{prefix}a link fault spec of {len(text)} characters is too long"
            f" (at most {MAX_SPEC_TEXT})"
        )
    values: dict[str, float | int | str] = {}
    for item in (p.strip() for p in text.split(",")):
        if not item:
            continue
        key, sep, raw = item.partition("=")
        key, raw = key.strip(), raw.strip()
        shown_key = shown(key)
        if not sep or not raw:
            raise InputError(f"{prefix}link fault {shown(item)} is not key=value (drop=0.05)")
        if key in values or f"{key}_s" in values:
            raise InputError(f"{prefix}link fault {shown_key} is given twice")
        if key in _PROBABILITIES:
            try:
                p = float(raw)
            except ValueError:
                raise InputError(f"{prefix}link fault {key}={shown(raw)}: not a number") from None
            if not 0.0 <= p <= 1.0:  # nan too
                raise InputError(
                    f"{prefix}link fault {key}={shown(raw)}: a probability must lie in [0, 1]"
                )
            values[key] = p
        elif key in ("delay", "jitter"):
            try:
                seconds = parse_quantity(raw, "time")
            except UnitError as exc:
                raise InputError(f"{prefix}link fault {key}: {exc}") from None
            if not 0.0 <= seconds <= 60.0:
                raise InputError(
                    f"{prefix}link fault {key}={shown(raw)}: must lie between 0 s and 60 s"
                )
            values[f"{key}_s"] = seconds
        elif key == "seed":
            try:
                values["seed"] = int(raw)
            except ValueError:
                raise InputError(
                    f"{prefix}link fault seed={shown(raw)}: not a whole number"
                ) from None
        elif key == "direction":
            if raw not in ("both", "tx", "rx"):
                raise InputError(f"{prefix}link fault direction={shown(raw)}: use both, tx or rx")
            values["direction"] = raw
        else:
            known = ", ".join([*_PROBABILITIES, "delay", "jitter", "seed", "direction"])
            raise InputError(f"{prefix}unknown link fault {shown_key} (known: {known})")
    return FaultSpec(**values)  # type: ignore[arg-type]


def split_fault_url(url: str) -> tuple[str, FaultSpec | None]:
    """Remove the ``faults=`` (and ``fault_seed=``) options from a port URL.

    ``loop://?faults=drop=0.1,dup=0.02&fault_seed=3`` gives ``("loop://", spec)``;
    other query options stay for pyserial.

    Args:
        url: A pyserial URL, possibly with fault options.

    Returns:
        The URL for pyserial and the fault spec (``None`` if none was given).

    Raises:
        InputError: the fault spec is malformed, or ``faults`` or ``fault_seed`` is
            given twice.
    """
    base, sep, query = url.partition("?")
    if not sep:
        return url, None
    keep: list[str] = []
    spec_text: str | None = None
    seed: str | None = None
    for part in query.split("&"):
        key, _, value = part.partition("=")
        if key in ("faults", "fault_seed") and (spec_text if key == "faults" else seed) is not None:
            # the last one silently won: faults=drop=0.1&faults=dup=0.2 dropped nothing
            raise InputError(
                f"faults: {key}= is given twice in the port URL; give it once"
                " (faults=drop=0.1,dup=0.2: the faults joined by commas)"
            )
        if key == "faults":
            spec_text = urllib.parse.unquote(value)
        elif key == "fault_seed":
            seed = value
        elif part:
            keep.append(part)
    clean = base + ("?" + "&".join(keep) if keep else "")
    if spec_text is None:
        if seed is not None:
            raise InputError("fault_seed given without faults")
        return clean, None
    if seed is not None:
        spec_text += f",seed={seed}"
    return clean, parse_fault_spec(spec_text)


class _Direction:
    """Faults for one direction: frame splitting and a release queue ordered by time."""

    def __init__(self, spec: FaultSpec, rng: random.Random, clock: Clock) -> None:
        self.spec = spec
        self.rng = rng
        self.clock = clock
        self.partial = bytearray()
        self.held: list[tuple[float, int, bytes]] = []  # (release time, order, frame)
        self.behind: bytes | None = None  # a frame waiting to be overtaken
        self.order = itertools.count()
        self.counts: dict[str, int] = dict.fromkeys(
            ("frames", "dropped", "corrupted", "duplicated", "reordered"), 0
        )

    def push(self, data: bytes) -> None:
        self.partial += data
        if b"\x00" not in self.partial:
            return
        *frames, rest = bytes(self.partial).split(b"\x00")
        self.partial = bytearray(rest)
        for body in frames:
            if body:
                self._frame(body + b"\x00")

    def _frame(self, frame: bytes) -> None:
        spec, rng = self.spec, self.rng
        self.counts["frames"] += 1
        if rng.random() < spec.drop:
            self.counts["dropped"] += 1
            return
        if rng.random() < spec.corrupt and len(frame) > 1:
            pos = rng.randrange(len(frame) - 1)  # never the delimiter itself
            buf = bytearray(frame)
            buf[pos] ^= rng.randrange(1, 256)
            frame = bytes(buf)
            self.counts["corrupted"] += 1
        copies = 2 if rng.random() < spec.dup else 1
        if copies == 2:
            self.counts["duplicated"] += 1
        for _ in range(copies):
            if self.behind is None and rng.random() < spec.reorder:
                self.behind = frame
                self.counts["reordered"] += 1
                continue
            self._schedule(frame)
            if self.behind is not None:
                self._schedule(self.behind)
                self.behind = None

    def _schedule(self, frame: bytes) -> None:
        delay = self.spec.delay_s
        if self.spec.jitter_s > 0:
            delay += self.rng.uniform(0.0, self.spec.jitter_s)
        heapq.heappush(self.held, (self.clock.now() + delay, next(self.order), frame))

    def due(self) -> bytes:
        now = self.clock.now()
        out: list[bytes] = []
        while self.held and self.held[0][0] <= now:
            out.append(heapq.heappop(self.held)[2])
        return b"".join(out)


class FaultyLink:
    """Wraps a byte link and injects faults frame by frame (a ``ByteLink`` itself).

    Args:
        inner: The real link (a :class:`~pirate_bt.link.transport.Transport`, ...).
        spec: What to inject.
        clock: The clock delays are measured on.
    """

    def __init__(self, inner: ByteLink, spec: FaultSpec, clock: Clock) -> None:
        self.inner = inner
        self.spec = spec
        self.clock = clock
        rng = random.Random(spec.seed)
        off = FaultSpec()
        self._tx = _Direction(spec if spec.direction in ("both", "tx") else off, rng, clock)
        self._rx = _Direction(spec if spec.direction in ("both", "rx") else off, rng, clock)

    @property
    def baud(self) -> int:
        return self.inner.baud

    @property
    def counts(self) -> dict[str, dict[str, int]]:
        """Frames seen and faults injected, per direction (``tx`` and ``rx``)."""
        return {"tx": dict(self._tx.counts), "rx": dict(self._rx.counts)}

    def write(self, data: bytes) -> None:
        """Pass ``data`` through the host -> bridge faults; write what is due."""
        self._tx.push(data)
        self._flush_tx()

    def _flush_tx(self) -> None:
        due = self._tx.due()
        if due:
            self.inner.write(due)

    def read_available(self) -> bytes:
        """Bridge -> host frames that survived and are due; also flushes delayed writes."""
        self._flush_tx()
        self._rx.push(self.inner.read_available())
        return self._rx.due()

    def drain_input(self) -> int:
        dropped = self.inner.drain_input() + len(self._rx.partial)
        self._rx.partial.clear()
        self._rx.held.clear()
        self._rx.behind = None
        return dropped

    def close(self) -> None:
        self.inner.close()
