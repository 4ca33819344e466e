"""A ``Connection`` sent to another process (``pool.submit(robot.run, ...)``) or copied
failed *cannot pickle '_thread.RLock' object*, naming nothing; it is refused now in one
line that says what to do instead.
"""

from __future__ import annotations

import copy
import pickle

import pytest

import pirate_bt


def test_a_connection_is_refused_by_pickle_and_copy_in_one_line() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        for attempt in (lambda: pickle.dumps(robot), lambda: copy.deepcopy(robot)):
            with pytest.raises(TypeError) as refused:
                attempt()
            message = str(refused.value)
            assert message.startswith(
                "connection: simulator: straight cannot be pickled or copied: it is this"
                " process's open link to its robot"
            )
            assert "pool.submit(pirate_bt.simulate_tree" in message
            assert isinstance(refused.value, pirate_bt.InputError)
        assert robot.run("straight", params={"distance": "0.1 m"}).status == "success"
