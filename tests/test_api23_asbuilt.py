"""The network edits of ``pirate_bt.pipes.asbuilt`` check their arguments as
``perturb_network`` does (docs/networks.md): one line naming the argument.

``insert_tee(spec, "run-b", "1.5 m")`` (a length as the command line writes it) and
``at_m=None`` were Python's bare ``TypeError`` from a comparison; ``keep_length="no"``
was true; ``name=5`` named the variant 5 and ``name=""`` gave the default unsaid;
``remove_feature(spec, None)`` said the network *has no None*, as if the id were only
unknown; ``network_yaml(network)`` and ``network_yaml(spec, header=5)`` raised
``AttributeError``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError, ArgumentValueError
from pirate_bt.pipes import Network
from pirate_bt.pipes.asbuilt import insert_tee, network_yaml, remove_feature


@pytest.fixture(scope="module")
def lab() -> Any:
    return pirate_bt.load_network("lab").spec


@pytest.mark.parametrize("at_m", ["1.5 m", "150 cm", 1.5, np.float64(1.5)])
def test_insert_tee_takes_a_length_as_text_or_a_number(lab: Any, at_m: Any) -> None:
    spec = insert_tee(lab, "run-b", at_m)
    ids = Network(spec).segment_ids()
    assert ids[ids.index("run-b") + 1] == "extra-tee"
    first = next(s for s in spec.segments if s.id == "run-b")
    assert first.length == pytest.approx(1.5)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (
            lambda lab: insert_tee(lab, "run-b", None),
            ArgumentTypeError,
            "at_m: give a distance into the straight (metres, or text such as '1.5 m'), not None",
        ),
        (lambda lab: insert_tee(lab, "run-b", "1.5 s"), ArgumentValueError, "at_m: "),
        (
            lambda lab: insert_tee(lab, "run-b", float("nan")),
            ArgumentValueError,
            "at_m: nan is not a finite number",
        ),
        (
            lambda lab: insert_tee(lab, "run-b", 1.5, keep_length="no"),
            ArgumentTypeError,
            "keep_length: give True or False, not 'no'",
        ),
        (
            lambda lab: insert_tee(lab, "run-b", 1.5, name=5),
            ArgumentTypeError,
            "name: give the variant's name as text, not an int",
        ),
        (
            lambda lab: remove_feature(lab, "tee-1", name=""),
            ArgumentValueError,
            "name: empty; give the variant's name, or None for the default",
        ),
        (
            lambda lab: remove_feature(lab, None),
            ArgumentTypeError,
            "segment_id: give a segment's id as text, not None",
        ),
        (
            lambda lab: insert_tee(lab, 3, 1.5),
            ArgumentTypeError,
            "segment_id: give a segment's id as text, not an int",
        ),
        (
            lambda lab: network_yaml(Network(lab)),
            ArgumentTypeError,
            "spec: give a NetworkSpec (a Network's is its .spec), not a Network",
        ),
        (
            lambda lab: network_yaml(lab, header=5),
            ArgumentTypeError,
            "header: give text, not an int",
        ),
    ],
)
def test_a_wrong_argument_is_one_line_naming_it(
    lab: Any, call: Any, error: type[Exception], message: str
) -> None:
    with pytest.raises(error) as raised:
        call(lab)
    assert isinstance(raised.value, pirate_bt.InputError)
    assert str(raised.value).startswith(message)
    assert "\n" not in str(raised.value)


def test_keep_length_takes_numpy_truth(lab: Any) -> None:
    kept = insert_tee(lab, "run-b", 1.5, keep_length=np.bool_(True))
    grown = insert_tee(lab, "run-b", 1.5)

    def rest(spec: Any) -> float:
        return float(next(s.length for s in spec.segments if s.id == "run-b-after"))

    assert rest(kept) < rest(grown)
