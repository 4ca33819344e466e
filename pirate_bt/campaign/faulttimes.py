"""A simulator fault that starts after the run's time limit: refused at its entry.

A tree, a navigator or a route's mission (re-planned rests included) ends at
``max_time`` at the latest, so a fault due at or after it never happens: its point of
the ``sim_faults`` axis ran the very runs of the point without it (a slip, ``@200s``
for ``@20s``, with ``max_time: 60 s``), counted as its own group in the report, all of
it ``success``.
"""

from __future__ import annotations

from pirate_bt.campaign.inputs import source_of
from pirate_bt.campaign.spec import CampaignSpec

__all__ = ["check_fault_times"]


def check_fault_times(spec: CampaignSpec) -> None:
    """Refuse a fault of ``sim_faults`` due at or after ``max_time``.

    Raises:
        InputError: at the fault's entry (a :class:`~pirate_bt.errors.LocatedError`
            for a file).
    """
    from pirate_bt.sim.faults import parse_fault

    limit = spec.quantity("max_time", "time")
    for i, point in enumerate(spec.sim_faults):
        for j, text in enumerate(point):
            at = parse_fault(text, option="").at
            if at >= limit:
                raise source_of(spec).error(
                    ("sim_faults", i, j),
                    f"{text!r} starts at {at:g} s, not before max_time ({spec.max_time}):"
                    " it would never happen, and its runs be those without it",
                )
