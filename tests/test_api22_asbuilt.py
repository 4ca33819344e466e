"""Session 22: perturb_network's bounds and name given as planner code gives them
(docs/networks.md, As-built variants): NaN, infinity, text or None refused in one line
naming the bound, NumPy values taken as the Python ones."""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError, ConfigurationError
from pirate_bt.pipes.asbuilt import AsBuiltBounds, network_yaml, perturb_network


@pytest.mark.parametrize(
    ("given", "kind", "said"),
    [
        (
            {"length_fraction": float("nan")},
            ConfigurationError,
            "length_fraction nan is not finite",
        ),
        ({"slope_rad": float("nan")}, ConfigurationError, "slope_rad nan is not finite"),
        ({"length_max_m": float("inf")}, ConfigurationError, "length_max_m inf is not finite"),
        ({"diameter_min_m": -1.0}, ConfigurationError, "diameter_min_m must be above 0"),
        (
            {"length_fraction": "0.1"},
            ArgumentTypeError,
            "length_fraction: give a number, not a str",
        ),
        ({"slope_rad": None}, ArgumentTypeError, "slope_rad: give a number, not None"),
    ],
    ids=["nan-length", "nan-slope", "inf-length-max", "negative-diameter", "text", "none"],
)
def test_bounds_a_variant_cannot_use_are_refused_naming_the_bound(
    given: dict[str, object], kind: type[Exception], said: str
) -> None:
    # nan was taken (every variant's lengths or slopes nan), text and None were a bare
    # TypeError ("'<' not supported between instances of 'str' and 'int'")
    with pytest.raises(kind) as caught:
        AsBuiltBounds(**given)  # type: ignore[arg-type]
    assert str(caught.value) == f"as-built bounds: {said}"


def test_a_nan_scale_is_refused() -> None:
    with pytest.raises(
        ConfigurationError, match=r"^as-built bounds: a scale of nan is not finite$"
    ):
        AsBuiltBounds().scaled(float("nan"))


def test_numpy_bounds_and_a_numpy_name_make_a_variant_yaml_can_write() -> None:
    numpy = pytest.importorskip("numpy")
    drawing = pirate_bt.load_network("straight").spec
    bounds = AsBuiltBounds(length_fraction=numpy.float64(0.2))
    assert type(bounds.length_fraction) is float
    variant = perturb_network(drawing, 3, bounds, name=numpy.str_("as-built 3"))
    # a numpy.str_ name was a yaml RepresenterError ('cannot represent an object')
    assert "name: as-built 3" in network_yaml(variant)
    assert variant == perturb_network(
        drawing, 3, AsBuiltBounds(length_fraction=0.2), name="as-built 3"
    )
