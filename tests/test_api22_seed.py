"""Session 22: one rule for a seed (pirate_bt.errors.seed_argument), below the API and
the pipes: the API's seed= and an as-built variant's seed are refused in the same
words, as the same kinds of error."""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError, ArgumentValueError


@pytest.mark.parametrize(
    ("seed", "kind"),
    [
        (-1, ArgumentValueError),
        (2**63, ArgumentValueError),
        (10**45, ArgumentValueError),
        (1.5, ArgumentTypeError),
        ("3", ArgumentTypeError),
        ("x" * 100, ArgumentTypeError),
        (True, ArgumentTypeError),
        ([1] * 30, ArgumentTypeError),
    ],
    ids=["negative", "past-max", "huge", "float", "text", "long-text", "bool", "list"],
)
def test_the_api_and_an_as_built_variant_refuse_a_seed_in_the_same_words(
    seed: object, kind: type[Exception]
) -> None:
    from pirate_bt.pipes.asbuilt import perturb_network

    drawing = pirate_bt.load_network("straight").spec
    with pytest.raises(kind) as by_the_api:
        pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, seed=seed)  # type: ignore[arg-type]
    with pytest.raises(kind) as by_the_variant:
        perturb_network(drawing, seed)  # type: ignore[arg-type]
    assert str(by_the_api.value) == str(by_the_variant.value)
    assert str(by_the_api.value).startswith("seed: give a whole number from 0 to 2**63 - 1, not ")
    assert len(str(by_the_api.value)) < 200
