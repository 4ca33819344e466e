"""Campaigns: many seeded simulated runs as one experiment, with figures a safety case can cite.

A campaign file (:mod:`~pirate_bt.campaign.spec`) is a matrix of trees or
routes, networks and maps, robots, seeds and faults. :func:`run_campaign` runs
one from a file, plain data or a model and returns a :class:`CampaignResult`.
Underneath, :func:`expand` turns the spec into plain cases (after
:func:`check_size` has counted them); :func:`run_cases` runs each in a process
of its own on a ``concurrent.futures`` executor (a local process pool, or a
Dask cluster's), forked from a case server each worker starts once
(:mod:`~pirate_bt.campaign.workers`), and appends one row per case;
:mod:`~pirate_bt.campaign.report` turns the rows into per-group statistics,
plots, Markdown, HTML and CSV.
"""

from pirate_bt.campaign.cases import (
    DEFAULT_MAX_CASES,
    check_inputs,
    check_size,
    expand,
    group_key,
)
from pirate_bt.campaign.engine import make_executor, read_rows, run_cases, run_isolated
from pirate_bt.campaign.run import CampaignResult, default_output, load_spec, run_campaign
from pirate_bt.campaign.spec import (
    CampaignSpec,
    campaign_from_data,
    campaign_schema,
    load_campaign,
)

__all__ = [
    "DEFAULT_MAX_CASES",
    "CampaignResult",
    "CampaignSpec",
    "campaign_from_data",
    "campaign_schema",
    "check_inputs",
    "check_size",
    "default_output",
    "expand",
    "group_key",
    "load_campaign",
    "load_spec",
    "make_executor",
    "read_rows",
    "run_campaign",
    "run_cases",
    "run_isolated",
]
