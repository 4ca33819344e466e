"""Campaigns: many seeded simulated runs as one experiment, with figures a safety case can cite.

A campaign file (:mod:`~pirate_bt.campaign.spec`) is a matrix of trees or
routes, networks and maps, robots, seeds and faults. :func:`expand` turns it
into plain cases; :func:`run_cases` runs each in its own process on a
``concurrent.futures`` executor (a local process pool, or a Dask cluster's)
and appends one row per case; :mod:`~pirate_bt.campaign.report` turns the rows
into per-group statistics, plots, Markdown, HTML and CSV.
"""

from pirate_bt.campaign.cases import expand, group_key
from pirate_bt.campaign.engine import make_executor, read_rows, run_cases, run_isolated
from pirate_bt.campaign.spec import CampaignSpec, campaign_schema, load_campaign

__all__ = [
    "CampaignSpec",
    "campaign_schema",
    "expand",
    "group_key",
    "load_campaign",
    "make_executor",
    "read_rows",
    "run_cases",
    "run_isolated",
]
