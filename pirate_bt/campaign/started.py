"""What a campaign records in its folder as it starts, and what ``--resume`` checks against it.

A case's row holds its parameters and its ``id`` a digest of them, so ``--resume``
refuses rows of a spec edited since (:func:`pirate_bt.campaign.engine.check_output`).
Two things change what a case does without changing its parameters: an input file
edited in place (a tree, a route, a network, a robot ... read from the same name),
and the wall-time limit given as ``--case-timeout`` (``case_timeout=``), which
overrides the spec's. Results of the old and the new would then be mixed in one
``results.jsonl``. So when a campaign first writes its folder (its results file
holds no line yet), it records both in ``OUT/campaign.json``::

    {"format": 1, "campaign": "NAME", "case_timeout_s": 120.0,
     "inputs": [{"file": "/abs/scenarios/lab.route", "sha256": "5f0c..."}, ...]}

``inputs`` are the files the checks before any case read
(:func:`pirate_bt.campaign.checks.check_runs`): every file the spec names and the
files those pull in (subtree files, a route's own network and its PAB trees, a
route navigator's route). ``--resume`` into a folder whose results file holds
rows refuses, before any worker starts and before anything is rewritten, an input
whose content changed (or that is gone, or that the campaign did not read when it
started) and a ``--case-timeout`` other than the one the campaign started with;
without ``--case-timeout`` it runs the remaining cases with that one. A folder
written before this record existed has none and resumes unchecked.

Nothing else is checked: the installed pirate_bt (its code, and the bundled files a
spec leaves to their defaults: the bundled robot, the ``straight`` network) is the
user's to keep the same.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pirate_bt.atomic import write_atomically
from pirate_bt.campaign.paths import OUTPUT, RESULTS_NAME, RESUME
from pirate_bt.errors import InputError, shown

__all__ = [
    "FORMAT",
    "RECORD_NAME",
    "Start",
    "begin",
    "file_digest",
    "holds_a_record",
    "recorded_name",
    "write_record",
]

RECORD_NAME = "campaign.json"
"""The file in the output folder that records how the campaign started."""

FORMAT = 1
"""The record's format (its ``format`` key)."""

_MAX_RECORD_BYTES = 64_000_000
"""The largest record read: far above any campaign's inputs (a line each)."""


_AGAIN = f"rerun without {RESUME} into another {OUTPUT}"
_HEX = re.compile(r"[0-9a-f]{64}")


@dataclass(frozen=True)
class Start:
    """How a campaign starts in its folder (:func:`begin`).

    Attributes:
        timeout_s: The wall-time limit to give every case, overriding the spec's
            (``None``: the spec's).
        record: What to write as ``OUT/campaign.json`` once the cases are about to
            start (:func:`write_record`); ``None``: the folder keeps the record it
            has (a resumed campaign) or none (one written before records existed).
    """

    timeout_s: float | None
    record: dict[str, Any] | None


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes, as hex.

    Raises:
        OSError: it cannot be read.
    """
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def begin(
    folder: Path,
    resume: bool,
    inputs: Sequence[Path],
    name: str,
    spec_timeout_s: float,
    given_timeout_s: float | None,
) -> Start:
    """Check a resumed campaign against its record, or make the record of a new one.

    Call with the folder held (:func:`pirate_bt.campaign.paths.campaign_lock`), after
    :func:`~pirate_bt.campaign.engine.check_output`: before any worker starts.

    Args:
        folder: The output folder.
        resume: Whether the campaign continues the rows there.
        inputs: The input files the checks read (resolved).
        name: The campaign's name.
        spec_timeout_s: The spec's ``case_timeout``, in seconds.
        given_timeout_s: ``--case-timeout`` (``case_timeout=``), or ``None``.

    Raises:
        InputError: resuming, one line: an input changed since the campaign started
            (``scenarios/lab.route: changed since the campaign in OUT started; rerun
            without resume=True into another output=``; ``pirate-bt campaign`` names its
            options), a case timeout other than the
            one it started with, another name than it started with, or a record that
            cannot be read.
    """
    if not resume or not _holds_a_line(folder / RESULTS_NAME):
        started_s = given_timeout_s if given_timeout_s is not None else spec_timeout_s
        record = {
            "format": FORMAT,
            "campaign": name,
            "case_timeout_s": started_s,
            "inputs": [{"file": str(p), "sha256": _digest_or_refuse(p)} for p in inputs],
        }
        return Start(given_timeout_s, record)
    recorded = _read_record(folder / RECORD_NAME)
    if recorded is None:  # written before records existed: resumed unchecked
        return Start(given_timeout_s, None)
    started_s, digests, started_name = recorded
    if started_name is not None and started_name != name:
        # the report would be written under the new name, campaign.json keep the old
        raise InputError(
            f"name: {shown(name)} is not {shown(started_name)}, the campaign in {folder};"
            f" name it {shown(started_name)} to resume it, or {_AGAIN}"
        )
    if given_timeout_s is not None and not _same(given_timeout_s, started_s):
        raise InputError(
            f"case_timeout: {given_timeout_s:g} s is not the {started_s:g} s the campaign in"
            f" {folder} started with; leave it out, or {_AGAIN}"
        )
    _check_inputs(folder, digests, inputs)
    return Start(None if _same(started_s, spec_timeout_s) else started_s, None)


def write_record(folder: Path, record: dict[str, Any]) -> None:
    """Write ``OUT/campaign.json`` whole (or not at all).

    Raises:
        InputError: it cannot be written.
    """
    data = (json.dumps(record, indent=1, allow_nan=False) + "\n").encode("utf-8")
    try:
        write_atomically(folder / RECORD_NAME, lambda stream: stream.write(data))
    except OSError as exc:
        raise InputError(
            f"{folder / RECORD_NAME}: cannot write: {exc.strerror or exc}; give another {OUTPUT}"
        ) from None


def _same(a: float, b: float) -> bool:
    """Two limits alike (``5 min`` and ``300 s``; ``0.1 h``, which is 360.00000000000006 s)."""
    return math.isclose(a, b, rel_tol=1e-9)


def _holds_a_line(path: Path) -> bool:
    """Whether the results file holds any line that is not blank (read up to the first)."""
    if not path.is_file():
        return False
    try:
        with path.open("rb") as stream:
            return any(line.strip() for line in stream)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the results: {exc.strerror or exc}") from None


def _shown(path: Path) -> str:
    """``path`` relative to the working folder when it is under it, else as it is."""
    try:
        return str(path.relative_to(Path.cwd()))
    except (ValueError, OSError):
        return str(path)


def _digest_or_refuse(path: Path) -> str:
    try:
        return file_digest(path)
    except OSError as exc:
        raise InputError(f"{_shown(path)}: cannot read: {exc.strerror or exc}") from None


def _read_record(path: Path) -> tuple[float, dict[str, str], str | None] | None:
    """The case timeout, the input digests and the campaign's name (``None`` if the
    record has none) a record holds; ``None`` without one.

    Raises:
        InputError: the record is not one a campaign wrote (edited, cut, too large).
    """
    if not path.exists():
        return None

    def refused(why: str) -> InputError:
        return InputError(
            f"{path}: not the record a campaign writes as it starts ({why}); {_AGAIN}"
        )

    try:
        if not path.is_file():
            raise refused("not a file")
        if path.stat().st_size > _MAX_RECORD_BYTES:
            raise refused(f"more than {_MAX_RECORD_BYTES:,} bytes")
        data = json.loads(path.read_bytes().decode("utf-8"))
    except OSError as exc:
        raise refused(f"cannot read it: {exc.strerror or exc}") from None
    except (ValueError, RecursionError):
        raise refused("not JSON") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise refused(f"no 'format': {FORMAT}")
    timeout = data.get("case_timeout_s")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
        raise refused("no case_timeout_s")
    if not (math.isfinite(timeout) and timeout > 0):
        raise refused("no case_timeout_s")
    inputs = data.get("inputs")
    digests: dict[str, str] = {}
    for entry in inputs if isinstance(inputs, list) else [None]:
        file = entry.get("file") if isinstance(entry, dict) else None
        digest = entry.get("sha256") if isinstance(entry, dict) else None
        if not isinstance(file, str) or not isinstance(digest, str) or not _HEX.fullmatch(digest):
            raise refused("inputs are not files with their sha256")
        digests[file] = digest
    name = data.get("campaign")
    return float(timeout), digests, name if isinstance(name, str) else None


def holds_a_record(folder: Path) -> bool:
    """Whether ``folder`` holds a campaign's record; for a folder holding no row.

    Raises:
        InputError: it holds a ``campaign.json`` no campaign wrote (a spec of that
            name run into its own folder, a project's file): the campaign's record
            would replace it, where it was overwritten without a word.
    """
    path = folder / RECORD_NAME
    try:
        return _read_record(path) is not None
    except InputError:
        raise InputError(
            f"{path}: the campaign's record would replace it, and it is no campaign's"
            f" ({folder} holds no row); move it, or give another {OUTPUT}"
        ) from None


def recorded_name(folder: Path) -> str | None:
    """The campaign's name ``folder/campaign.json`` records (the report's title), or
    ``None``: no record, not one a campaign wrote, or a name no title can hold."""
    try:
        record = _read_record(folder / RECORD_NAME)
    except InputError:
        return None
    name = record[2] if record is not None else None
    return name if name is not None and name.isprintable() and 0 < len(name) <= 100 else None


def _check_inputs(folder: Path, digests: dict[str, str], inputs: Sequence[Path]) -> None:
    """Refuse the first recorded input whose content changed or that is gone, then the
    first input read now that was not when the campaign started; one line."""
    since = f"since the campaign in {folder} started"
    problems: list[str] = []
    for file, digest in digests.items():
        path = Path(file)
        try:
            now = file_digest(path) if path.is_file() else None
        except OSError:
            now = None
        if now != digest:
            problems.append(f"{_shown(path)}: {'gone' if now is None else 'changed'} {since}")
    problems += [
        f"{_shown(p)}: an input now, but not when the campaign in {folder} started"
        for p in inputs
        if str(p) not in digests
    ]
    if problems:
        more = len(problems) - 1
        also = f" (and {more} more input file{'s' if more != 1 else ''})" if more else ""
        raise InputError(f"{problems[0]}{also}; {_AGAIN}")
