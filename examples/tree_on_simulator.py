"""Run the bend PAB on the simulator with a stalled wheel, and say why it failed.

Run from the repository root: ``python examples/tree_on_simulator.py``.

The stall makes the tree FAIL on purpose: a failed run is a result, not an
exception, so this script prints the cause and exits 0.
"""

import pirate_bt

# The bundled tree "bend" (trees/bend.yaml) in the bundled network "bend-right";
# one drive motor stalls 5 s into the run, for 20 s.
result = pirate_bt.simulate_tree(
    "bend",
    network="bend-right",
    params={"roll": "90 deg"},  # text with a unit, as on the command line
    faults="motor_stall:bend_3_drive@5s+20s",
)
print("status:", result.status)  # "failure"
print("why:   ", result.why)  # the first cause, not "tree failed after N ticks"
print("where: ", result.failing_node)  # the path of the node that failed

# The same in one line, as `pirate-bt run` prints it, and what the run counted.
print(result.summary())
c = result.counters
print(f"left in its safe state: {result.safe_state}")
print(f"counters: {c.violations} violations, {c.refusals} refusals, {c.clips} clips")
