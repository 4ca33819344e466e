"""Run the benchmarks, collect the tables they publish, and rewrite docs/performance.md.

``make bench`` runs::

    .venv/bin/python benchmarks/run_all.py --write docs/performance.md

which runs every ``benchmarks/bench_*.py`` in turn (in this order, one at a time: the
machine's cores are theirs), each with ``PIRATE_BENCH_RESULTS`` set to one temporary
directory, so that the tables they publish (``report.publish``) land there; then,
if every one of them succeeded, rewrites the marked tables of the document from
those results (``report.py --write``). A benchmark that fails stops the run, and
the document is not written.

Most scripts run with their own defaults. Those that run hundreds of missions get
a quick default here (:data:`QUICK`); ``--full`` runs every script with its own
defaults, ``--set NAME=ARGS`` gives one script other arguments, and naming scripts
(``mission trace``) runs only those (the other tables stay as they are)::

    .venv/bin/python benchmarks/run_all.py --full --write docs/performance.md
    .venv/bin/python benchmarks/run_all.py trace interop --set interop="5 --no-sizes" \\
        --write docs/performance.md
    .venv/bin/python benchmarks/run_all.py --list

``--results DIR`` keeps the results (``make bench-doc BENCH_RESULTS=DIR`` writes
them into the document again later).
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))
import report  # noqa: E402 - this directory is not a package

QUICK: dict[str, list[str]] = {
    "asbuilt": ["-n", "10", "--scales", "1"],
    "navigators": ["-n", "4"],
    "survey": ["--count", "2"],
}
"""``make bench``'s arguments for the scripts whose defaults run hundreds of missions
(their defaults take 3 to 25 minutes each on the 2-core machine; ``--full`` uses them)."""


def short(script: Path) -> str:
    """``bench_mission.py`` -> ``mission``."""
    return script.stem.removeprefix("bench_")


def scripts(folder: Path = HERE) -> list[Path]:
    """Every benchmark script of a folder, in name order."""
    return sorted(folder.glob("bench_*.py"))


def plan(
    chosen: Sequence[Path],
    full: bool = False,
    overrides: Mapping[str, Sequence[str]] | None = None,
) -> list[tuple[Path, list[str]]]:
    """Each script with the arguments it runs with."""
    overrides = overrides or {}
    out = []
    for script in chosen:
        name = short(script)
        if name in overrides:
            args = list(overrides[name])
        else:
            args = [] if full else list(QUICK.get(name, []))
        out.append((script, args))
    return out


def run(
    steps: Sequence[tuple[Path, Sequence[str]]],
    results: Path,
    doc: Path | None,
    cwd: Path = REPO,
) -> int:
    """Run each step with results collected in ``results``, then rewrite ``doc``.

    Returns:
        0 when every benchmark succeeded (and the document was rewritten, if asked);
        1 when one failed (nothing written); the rewriter's code otherwise.
    """
    env = {**os.environ, report.RESULTS_ENV: str(results)}
    took: list[tuple[str, float]] = []
    started = time.perf_counter()
    for script, args in steps:
        shown = os.path.relpath(script, cwd)
        print(f"== {shlex.join([shown, *args])}", flush=True)
        begin = time.perf_counter()
        try:
            code = subprocess.run([sys.executable, shown, *args], cwd=cwd, env=env).returncode
        except KeyboardInterrupt:
            print(f"error: interrupted in {shown}; nothing written", file=sys.stderr)
            return 1
        took.append((shown, time.perf_counter() - begin))
        if code != 0:
            print(
                f"error: {shown} failed (exit {code})"
                + (f"; {doc} not written" if doc is not None else ""),
                file=sys.stderr,
            )
            return 1
    total = time.perf_counter() - started
    print("\n== time per benchmark")
    for shown, seconds in took:
        print(f"{seconds:8.1f} s  {shown}")
    print(f"{total:8.1f} s  in all ({total / 60:.1f} min)")
    if doc is None:
        return 0
    return report.main(["--write", str(doc), str(results)])


def _overrides(items: Sequence[str]) -> dict[str, list[str]]:
    out = {}
    for item in items:
        name, sep, args = item.partition("=")
        if not sep:
            raise SystemExit(f"error: --set {item!r}: expected NAME=ARGS, e.g. interop='5'")
        out[name.removeprefix("bench_").removesuffix(".py")] = shlex.split(args)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="run only these (mission, trace, ...)")
    parser.add_argument("--write", type=Path, metavar="DOC", help="rewrite DOC's marked tables")
    parser.add_argument("--results", type=Path, metavar="DIR", help="keep the results here")
    parser.add_argument("--full", action="store_true", help="every script's own defaults")
    parser.add_argument(
        "--set", action="append", default=[], metavar="NAME=ARGS", help="one script's arguments"
    )
    parser.add_argument("--list", action="store_true", help="print what would run; run nothing")
    args = parser.parse_args(argv)
    every = scripts()
    by_name = {short(s): s for s in every}
    wanted = [n.removeprefix("bench_").removesuffix(".py") for n in args.names]
    unknown = [n for n in wanted if n not in by_name]
    if unknown:
        parser.error(f"no benchmark {', '.join(unknown)} (there are: {', '.join(by_name)})")
    overrides = _overrides(args.set)
    unknown = [n for n in overrides if n not in by_name]
    if unknown:  # a typo would otherwise run that script with its defaults, silently
        parser.error(f"--set: no benchmark {', '.join(unknown)} (there are: {', '.join(by_name)})")
    steps = plan([by_name[n] for n in wanted] or every, args.full, overrides)
    if args.list:
        for script, script_args in steps:
            print(shlex.join([os.path.relpath(script, REPO), *script_args]))
        return 0
    if args.write is not None:  # markers that do not pair up: say so before an hour of runs
        try:
            text = args.write.read_text(encoding="utf-8")
            report.find_blocks(text.splitlines(keepends=True), str(args.write))
        except (OSError, report.MarkerError) as exc:
            print(f"error: {exc}; nothing run", file=sys.stderr)
            return 2
    if args.results is not None:
        args.results.mkdir(parents=True, exist_ok=True)
        return run(steps, args.results.resolve(), args.write)
    folder = Path(tempfile.mkdtemp(prefix="pirate-bench-"))
    try:
        return run(steps, folder, args.write)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())
