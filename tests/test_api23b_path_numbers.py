"""A path through a network takes a distance as a NumPy 0-d array, as it takes a NumPy
number: ``path.diameter_at(numpy.array(1.0))`` was refused *s_m: give a distance along
the path in metres (a number), not a ndarray* while ``numpy.float32(1.0)`` was taken."""

from __future__ import annotations

import numpy as np
import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError


def test_a_0d_array_is_a_distance_as_its_number_is() -> None:
    path = pirate_bt.load_network("lab").main_path()
    assert path.index_at(np.array(1.0)) == path.index_at(1.0)
    assert path.diameter_at(np.array(1.0)) == path.diameter_at(1.0)
    assert path.position_at(np.array(2, dtype=np.int32)) == path.position_at(2.0)
    with pytest.raises(ArgumentTypeError, match="not a ndarray"):
        path.index_at(np.array([1.0]))  # a vector is no distance
