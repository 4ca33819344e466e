"""``make mutation``: mutmut on the protective layer and the wire, then a score per module.

The modules and the tests that exercise them are ``[tool.mutmut]`` in ``pyproject.toml``
(docs/testing.md says why these). This script

1. runs ``mutmut run`` with at most ``--children`` test processes. mutmut keeps every
   result in ``mutants/``, so an interrupted run resumes where it stopped, and a later
   run tests only the mutants of functions that changed;
2. tests the surviving mutants again when the tests changed since their verdict (mutmut
   keeps a survivor's verdict even when a new test would kill it);
3. prints the score of each module (killed, timeouts count as killed, over all
   mutants but skipped ones) and its survivors, writes ``mutants/scores.json``, and
   with ``--update-docs`` the score table in ``docs/testing.md``;
4. exits 1 when a module is below the threshold (95 %).

Delete ``mutants/`` for a run from scratch (the figures in docs/testing.md are from one).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import re
import subprocess
import sys
import time
import tomllib
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MUTANTS = ROOT / "mutants"
DOCS = ROOT / "docs" / "testing.md"
THRESHOLD = 0.95
FINGERPRINT = MUTANTS / "pirate-bt-tests.sha256"
"""Hash of the test files when the survivors were last tested (step 2)."""

# mutmut's exit codes per mutant (mutmut/stats.py), as this report counts them.
KILLED = {1, 3}
TIMEOUT = {-24, 24, 36, 152, 255}
SURVIVED = {0, 5, 33}  # survived, or no test covers the mutated function
SKIPPED = {34, 37}
NOT_RUN = {None}

BLOCK_START = "<!-- mutation-scores:start -->"
BLOCK_END = "<!-- mutation-scores:end -->"


def config() -> dict[str, object]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    mutmut: dict[str, object] = data["tool"]["mutmut"]
    return mutmut


def modules() -> list[str]:
    only = config()["only_mutate"]
    assert isinstance(only, list)
    return [str(m) for m in only]


def mutmut(*args: str) -> int:
    exe = Path(sys.executable).with_name("mutmut")
    return subprocess.run([str(exe), *args], cwd=ROOT, check=False).returncode


def results() -> dict[str, dict[str, int | None]]:
    """Exit code per mutant name, per module path (from mutmut's ``.meta`` files)."""
    out: dict[str, dict[str, int | None]] = {}
    for module in modules():
        meta = MUTANTS / f"{module}.meta"
        if meta.exists():
            out[module] = json.loads(meta.read_text())["exit_code_by_key"]
        else:
            out[module] = {}
    return out


def tests_fingerprint() -> str:
    digest = hashlib.sha256()
    for path in sorted((ROOT / "tests").rglob("*.py")):
        if "mutants" in path.parts:
            continue
        digest.update(str(path.relative_to(ROOT)).encode())
        digest.update(path.read_bytes())
    digest.update(json.dumps(config(), sort_keys=True).encode())
    return digest.hexdigest()


def survivors(found: dict[str, dict[str, int | None]]) -> list[str]:
    return sorted(name for codes in found.values() for name, c in codes.items() if c in SURVIVED)


def score(codes: dict[str, int | None]) -> dict[str, object]:
    counts = Counter(
        "killed"
        if c in KILLED
        else "timeout"
        if c in TIMEOUT
        else "survived"
        if c in SURVIVED
        else "skipped"
        if c in SKIPPED
        else "not run"
        if c in NOT_RUN
        else "suspicious"
        for c in codes.values()
    )
    judged = sum(counts.values()) - counts["skipped"] - counts["not run"]
    caught = counts["killed"] + counts["timeout"]
    return {
        "mutants": len(codes),
        "killed": counts["killed"],
        "timeout": counts["timeout"],
        "survived": counts["survived"],
        "suspicious": counts["suspicious"],
        "skipped": counts["skipped"],
        "not_run": counts["not run"],
        "score": caught / judged if judged else 0.0,
    }


def table(scores: dict[str, dict[str, object]]) -> str:
    lines = [
        "| module | mutants | killed | timeouts | survived | score |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for module, s in scores.items():
        lines.append(
            f"| `{module}` | {s['mutants']} | {s['killed']} | {s['timeout']} |"
            f" {s['survived']} | {100 * float(s['score']):.1f} % |"  # type: ignore[arg-type]
        )
    return "\n".join(lines)


def update_docs(scores: dict[str, dict[str, object]], minutes: float | None) -> None:
    text = DOCS.read_text()
    today = datetime.date.today().isoformat()
    took = f", {minutes:.0f} min on this machine" if minutes is not None else ""
    block = f"{BLOCK_START}\nMeasured {today}{took}:\n\n{table(scores)}\n{BLOCK_END}"
    pattern = re.compile(re.escape(BLOCK_START) + ".*?" + re.escape(BLOCK_END), re.S)
    if not pattern.search(text):
        raise SystemExit(f"{DOCS}: no {BLOCK_START} ... {BLOCK_END} block to update")
    DOCS.write_text(pattern.sub(lambda _: block, text))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--children", type=int, default=2, help="test processes (default 2)")
    parser.add_argument("--report-only", action="store_true", help="no run: report mutants/")
    parser.add_argument("--update-docs", action="store_true", help="write the scores in the docs")
    args = parser.parse_args(argv)

    started = time.monotonic()
    if not args.report_only:
        if mutmut("run", "--max-children", str(args.children)) != 0:
            print("mutmut run failed", file=sys.stderr)
            return 2
        fingerprint = tests_fingerprint()
        recorded = FINGERPRINT.read_text().strip() if FINGERPRINT.exists() else None
        left = survivors(results())
        if recorded is not None and recorded != fingerprint and left:
            print(f"the tests changed since these verdicts: testing {len(left)} survivors again")
            if mutmut("run", "--max-children", str(args.children), *left) != 0:
                return 2
        FINGERPRINT.write_text(fingerprint + "\n")
    minutes = (time.monotonic() - started) / 60 if not args.report_only else None

    found = results()
    scores = {module: score(codes) for module, codes in found.items()}
    print()
    print(table(scores))
    for name in survivors(found):
        print(f"  survived: {name}")
    MUTANTS.mkdir(exist_ok=True)
    (MUTANTS / "scores.json").write_text(json.dumps(scores, indent=2) + "\n")
    if args.update_docs:
        update_docs(scores, minutes)
    unjudged = sum(int(s["not_run"]) for s in scores.values())  # type: ignore[call-overload]
    if unjudged:
        print(f"{unjudged} mutants not tested yet (an interrupted run?)", file=sys.stderr)
        return 1
    low = [m for m, s in scores.items() if float(s["score"]) < THRESHOLD]  # type: ignore[arg-type]
    if low:
        print(f"below {THRESHOLD:.0%}: {', '.join(low)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
