"""``run_campaign``'s numbers may be NumPy's, as every other function of the API takes
them: ``workers=numpy.int64(1)`` was refused *workers: give a whole number, not
np.int64(1)*, and ``case_timeout=numpy.float32(90)`` as no duration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pirate_bt.campaign.run import run_campaign
from pirate_bt.errors import InputError

SPEC = {
    "name": "n",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.05 m"}}],
    "seeds": {"count": 1},
    "max_time": "60 s",
}


def test_numpy_numbers_and_flags_are_taken_as_python_s(tmp_path: Path) -> None:
    said: list[str] = []
    result = run_campaign(
        SPEC,
        workers=np.int64(1),
        max_cases=np.int32(10),
        case_timeout=np.float32(90),
        progress=np.bool_(False),
        output=tmp_path / "out",
        echo=said.append,
    )
    assert result.counts["success"] == 1
    assert said and said[0].endswith(f"on 1 local worker -> {tmp_path / 'out'}")


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ({"workers": np.int64(0)}, "workers must be at least 1"),
        ({"workers": np.float64(1.0)}, "workers: give a whole number, not 1.0"),
        ({"max_cases": np.int64(0)}, "max_cases must be at least 1"),
    ],
)
def test_numpy_numbers_are_still_checked(option: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        run_campaign(SPEC, **option)  # type: ignore[arg-type]
