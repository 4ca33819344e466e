"""Write your own path-finding algorithm: a random explorer (docs/navigators.md).

At every T-joint it picks a way at random, at every bend it turns as the map says,
and at the end of the pipe it stops. Run it: ``python examples/random_explorer.py``.
"""

import random

import pirate_bt
from pirate_bt import Observation, Step


class RandomExplorer:
    def __init__(self, seed: int = 0) -> None:
        self.rng = random.Random(seed)

    def next_step(self, obs: Observation) -> Step | None:
        if obs.last is not None and obs.last.outcome != "success":
            return None  # a step failed: stop here (the result says why)
        ahead = obs.next_feature()
        if ahead is not None and ahead.kind == "bend":
            return Step("bend", direction=ahead.turn)
        if ahead is not None:
            return Step("t-joint", direction=self.rng.choice(["straight", ahead.branch]))
        left = obs.to_end_m()
        if left is not None and left > 0.2:
            return Step("straight", distance=left - 0.1)  # to 10 cm short of the end
        return None


for seed in (0,):  # try others: each seed explores its own way
    result = pirate_bt.navigate(RandomExplorer(seed), sim="lab", map="lab")
    ways = {tee: way for tee, way in result.decisions[-1].observation.choices.items()}
    print(f"seed {seed}: {result.status} after {result.steps} steps, ways taken {ways}")
    print(f"  why: {result.why}")
    print(f"  ended at {result.belief_m:.2f} m ({result.decisions[-1].observation.belief.segment})")
