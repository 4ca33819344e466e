"""A resume of a campaign whose every case already has its row starts nothing: no
local pool, no cluster reached. It started a worker pool to run nothing and said so,
"(2 done, 0 to run) on 1 local worker"; with a scheduler that no longer answers it
waited for it, then failed, though there was nothing to run."""

from __future__ import annotations

import socket
from pathlib import Path

from pirate_bt.campaign.run import run_campaign

SPEC = {
    "name": "r",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.05 m"}}],
    "seeds": {"count": 2},
    "max_time": "60 s",
}


def test_a_resume_with_every_case_done_says_so_and_starts_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    first = run_campaign(SPEC, workers=1, output=out)
    assert first.counts["success"] == 2
    rows = (out / "results.jsonl").read_text(encoding="utf-8")
    said: list[str] = []
    again = run_campaign(SPEC, workers=1, output=out, resume=True, echo=said.append)
    assert said == [f"campaign r: 2 cases (2 done, 0 to run): all done, no worker started -> {out}"]
    assert again.counts["success"] == 2 and again.rows == first.rows
    assert (out / "results.jsonl").read_text(encoding="utf-8") == rows
    assert (out / "report.md").is_file()
    # a cluster that no longer answers is not reached: there is nothing to send it
    silent = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        silent.bind(("127.0.0.1", 0))
        silent.listen(1)
        host, port = silent.getsockname()
        said.clear()
        on_cluster = run_campaign(
            SPEC,
            scheduler=f"tcp://{host}:{port}",
            scheduler_timeout="2 s",
            output=out,
            resume=True,
            echo=said.append,
        )
    finally:
        silent.close()
    assert said == [f"campaign r: 2 cases (2 done, 0 to run): all done, no worker started -> {out}"]
    assert on_cluster.rows == first.rows
