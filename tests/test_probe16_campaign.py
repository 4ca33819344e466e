"""The sixteenth probe of campaigns: what a user meets with hostile outputs and specs.

1. A disk that filled while a campaign ran: ``results.jsonl`` was left cut in the
   middle of a row (8 kB of buffered rows went out in part) and the command said
   only ``pirate-bt: No space left on device``, naming no file. Now each row is one
   append, a refused one is undone to the last whole row, and the error names the
   file, the case and says to ``--resume``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from pirate_bt.campaign import make_executor, read_rows, run_cases
from pirate_bt.campaign.sink import RowSink
from pirate_bt.errors import InputError

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs Linux")

HELPER = textwrap.dedent(
    """
    def behave(case, trace_dir):
        return {"id": case["id"], "index": case["index"], "run": case["run"],
                "outcome": "success", "reason": "fine " + "x" * 200, "seed": case["seed"]}
    """
)


def _cases(n: int) -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-p16", "index": i, "run": "r", "seed": i, "timeout_s": 60.0}
        for i in range(n)
    ]


@pytest.fixture
def helper(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "probe16_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    return tmp_path


# The campaign in a Python of its own whose files may not grow past LIMIT bytes
# (RLIMIT_FSIZE: a write past it fails with EFBIG, as one fails on a full disk).
FULL = textwrap.dedent(
    """
    import resource, sys
    from pathlib import Path
    from pirate_bt.campaign import make_executor, run_cases
    from pirate_bt.errors import InputError
    sys.path.insert(0, sys.argv[1])
    from test_probe16_campaign import _cases
    limit = int(sys.argv[3])
    with make_executor(workers=1) as (executor, _):
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        try:
            run_cases(_cases(6), Path(sys.argv[2]), executor, target="probe16_helper:behave")
        except InputError as exc:
            print(exc, file=sys.stderr)
            sys.exit(2)
    """
)


def test_a_disk_that_fills_leaves_whole_rows_and_names_the_results_file(helper: Path) -> None:
    out = helper / "out"
    # the size of two rows and a half
    row = len(json.dumps({"id": "000000-p16", "index": 0, "run": "r"})) + 240
    done = subprocess.run(
        [sys.executable, "-c", FULL, str(Path(__file__).parent), str(out), str(row * 5 // 2)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    results = out / "results.jsonl"
    assert lines[0].startswith(f"{results}: cannot write case 0000"), lines[0]
    assert "--resume" in lines[0]
    text = results.read_text(encoding="utf-8")
    assert text.endswith("\n")  # no cut row
    kept = [json.loads(line) for line in text.splitlines()]
    assert 1 <= len(kept) < 6
    # and --resume, with room again, runs exactly the missing cases
    with make_executor(workers=1) as (executor, _):
        rows = run_cases(_cases(6), out, executor, resume=True, target="probe16_helper:behave")
    assert [r["index"] for r in rows] == list(range(6))
    assert [r["index"] for r in read_rows(results)] == [r["index"] for r in kept] + [
        i for i in range(6) if i not in {r["index"] for r in kept}
    ]


def test_a_row_the_file_system_refuses_names_the_file() -> None:
    with RowSink(Path("/dev/full")) as sink, pytest.raises(InputError) as caught:
        sink.write({"id": "000003-ab", "index": 3})
    assert str(caught.value).startswith("/dev/full: cannot write case 000003-ab's row: No space")
