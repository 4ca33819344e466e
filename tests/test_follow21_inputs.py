"""Session 21, follow-ups of input checks: perturb_network takes the seeds every other
seed is (0 to 2**63 - 1); `mission --port` checks its URL's scheme before planning."""

from __future__ import annotations

import pytest

from pirate_bt.errors import InputError


@pytest.mark.parametrize(
    ("seed", "shown"),
    [(-1, "-1"), (2**63, "9223372036854775808"), (1.5, "1.5"), ("3", "'3'"), (True, "True")],
    ids=["negative", "past-max", "float", "text", "bool"],
)
def test_perturb_network_refuses_a_seed_no_campaign_takes(seed: object, shown: str) -> None:
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import perturb_network

    drawing = load_network("lab").spec
    # -1 gave variant 1 (Python's random seeds by the number's size); 1.5 and '3' others
    with pytest.raises(InputError) as caught:
        perturb_network(drawing, seed)  # type: ignore[arg-type]
    assert str(caught.value) == f"seed: give a whole number from 0 to 2**63 - 1, not {shown}"


def test_perturb_network_takes_every_seed_a_campaign_does() -> None:
    np = pytest.importorskip("numpy")
    from pirate_bt.pipes import load_network
    from pirate_bt.pipes.asbuilt import perturb_network

    drawing = load_network("lab").spec
    assert perturb_network(drawing, np.int64(3)) == perturb_network(drawing, 3)
    assert perturb_network(drawing, 0) != perturb_network(drawing, 1)
    perturb_network(drawing, 2**63 - 1)
