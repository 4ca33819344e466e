"""Link-layer findings of a probe, each pinned by a test that failed before its fix.

1. A round trip longer than the retry budget made the unacknowledged release of the
   bridge's boot latch look like a latched e-stop (exit 1) instead of a link error.
"""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import LinkTimeout

# -- 1. the boot latch release never acknowledged is a link error ----------------------------


def test_a_boot_latch_release_never_acknowledged_is_a_link_timeout() -> None:
    with pytest.raises(
        LinkTimeout, match="did not acknowledge the release of its boot latch"
    ) as exc:
        pirate_bt.simulate_tree(
            "straight", params={"distance": "1 m"}, network="straight", faults="delay=120ms"
        )
    assert exc.value.exit_code == 3
    assert "0.238 s" in str(exc.value)


def test_the_cli_exits_3_when_the_boot_latch_release_is_not_acknowledged(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(
        [
            "run",
            "trees/straight.yaml",
            "--param",
            "distance=1m",
            "--sim",
            "straight",
            "--faults",
            "delay=150ms",
        ]
    )
    assert code == 3
    err = capsys.readouterr().err
    assert "boot latch" in err
    assert "e-stop: the bridge reports its e-stop latched" not in err
