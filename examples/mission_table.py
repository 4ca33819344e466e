"""Plan a route, run it on the simulator and print one line per PAB.

Run from the repository root: ``python examples/mission_table.py``.

A wheel stalls in the bend, so the table shows every outcome a PAB can have:
``success``, ``failure`` (with its cause) and ``not run``. Leave out
``faults=`` for a clean run; ``"lab.route"`` is the long mission of ``make demo``.
"""

import pirate_bt

# A route is plain words (scenarios/bend-right.route); it names its own map.
mission = pirate_bt.simulate_mission(
    "scenarios/bend-right.route",
    faults="motor_stall:bend_3_drive@25s+20s",
)


def seconds(t: float | None) -> str:
    return "-" if t is None else f"{t:.1f}"


width = max(len(pab.label) for pab in mission.pabs)
print(f"{'PAB':<{width}}  {'kind':<8} {'outcome':<8} {'start s':>8} {'end s':>8}  why")
for pab in mission.pabs:
    print(
        f"{pab.label:<{width}}  {pab.kind:<8} {pab.outcome:<8}"
        f" {seconds(pab.start_s):>8} {seconds(pab.end_s):>8}  {pab.why}".rstrip()
    )

print()
print(f"mission: {mission.status} - {mission.why}")
if mission.failing_node:
    print(f"failed at: {mission.failing_node}")
c = mission.counters
print(
    f"counters: {c.violations} violations, {c.damage} damage, {c.refusals} refusals,"
    f" {c.clips} clips, {c.safe_states} safe states, {c.retries} link retries"
)
