"""NumPy scalars given to the API as the Python values they stand for (docs/api.md,
*Arguments the API refuses*): a planner script's numbers often come out of NumPy."""

from __future__ import annotations

import pickle

import pytest

import pirate_bt

numpy = pytest.importorskip("numpy")


def test_a_numpy_bool_is_a_boolean_parameter_and_a_numpy_number_a_length() -> None:
    # numpy.bool_(True) was refused: "parameter 'stop_at_feature': expected a boolean,
    # got np.True_"
    tree = pirate_bt.load_tree(
        "straight",
        params={
            "distance": numpy.float32(0.25),
            "stop_at_feature": numpy.bool_(True),
            "stop_at_change": numpy.bool_(False),
            "distance_key": numpy.str_(""),
        },
        check_robot=numpy.bool_(True),
    )
    assert tree.params["stop_at_feature"] is True
    assert tree.params["stop_at_change"] is False
    assert tree.params["distance"] == "0.25 m"
    pickle.dumps(tree.params)


def test_a_numpy_scalar_stands_for_its_python_value_in_every_option() -> None:
    from pirate_bt.api.options import flag, fraction, params_mapping, plain_number

    assert flag(numpy.bool_(False), "realtime") is False
    assert fraction(numpy.float32(0.25), "map_tolerance") == 0.25
    given = params_mapping({"a": numpy.bool_(True), "b": numpy.int16(3), "c": numpy.str_("x")})
    assert given == {"a": True, "b": 3, "c": "x"}
    assert [type(v) for v in given.values()] == [bool, int, str]
    assert type(plain_number(numpy.float64(0.5))) is float
    with pytest.raises(pirate_bt.InputError, match="realtime: give True or False"):
        flag(numpy.int8(1), "realtime")


def test_a_numpy_false_turns_a_live_view_off_and_a_numpy_domain_id_is_a_number() -> None:
    # numpy.bool_(False) was refused as "foxglove: give True, an address 'HOST:PORT' or an
    # open FoxgloveServer, not a bool"; numpy.int64(3) as a ROS domain id "from 0 to 232"
    off = numpy.bool_(False)
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.05 m"}, foxglove=off, ros2=off, groot2=off
    )
    assert result.succeeded
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_tree(
            "straight", params={"distance": "0.05 m"}, ros_domain_id=numpy.int64(3)
        )
    assert str(caught.value) == "ros_domain_id and ros_namespace are for ros2=; give ros2= too"
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_tree(
            "straight", params={"distance": "0.05 m"}, groot2=numpy.int64(70000)
        )
    assert str(caught.value) == "groot2: the port must be a number from 0 to 65534"


def test_numpy_text_names_and_values_of_parameters_are_plain_text() -> None:
    yaml = pytest.importorskip("yaml")
    # a numpy.str_ name stayed one in LoadedTree.params: yaml.safe_dump refused it
    # ("cannot represent an object")
    tree = pirate_bt.load_tree("straight", params={numpy.str_("distance"): numpy.str_("0.2 m")})
    assert {type(name) for name in tree.params} == {str}
    assert "distance: 0.2 m" in yaml.safe_dump(dict(tree.params))
