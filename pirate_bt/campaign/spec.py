"""The campaign file (``*.campaign.yaml``): a matrix of what to run, many times.

A campaign is the cross product of its axes::

    runs      what runs: a tree with parameters in a network, or a route
    robots    robot descriptions (``null``: the bundled robot)
    maps      the simulated truth each route runs in (``null``: truth = the map)
    link      link byte faults, each key a list of rates (a grid): drop, corrupt, dup
    sim_faults lists of simulator faults (``KIND[:TARGET]@AT[+DURATION]``)
    seeds     a range ``{start, count}``

Every combination except the seed is a *group*; the report gives one row per
group. The order of expansion is fixed (runs, robots, maps, sim faults, link
grid, seeds), so case ids are the same wherever the campaign runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from pirate_bt.errors import UnitError
from pirate_bt.units import parse_quantity
from pirate_bt.yamlfile import load_yaml, validate_document

__all__ = [
    "CampaignSpec",
    "LinkAxes",
    "RunItem",
    "SeedRange",
    "campaign_schema",
    "load_campaign",
]

_STRICT = ConfigDict(extra="forbid", frozen=True)


class RunItem(BaseModel):
    """One thing to run: a PAB or other tree in a network, or a route.

    Exactly one of ``tree`` and ``route`` is given.
    """

    model_config = _STRICT

    name: str | None = Field(None, description="label in the report (default: the file's stem)")
    tree: str | None = Field(None, description="a behaviour tree file or bundled name")
    route: str | None = Field(None, description="a route file (.route) or bundled name")
    network: str | None = Field(
        None,
        description="the pipe network (tree: the simulated world, default straight;"
        " route: the map, default the route's own network)",
    )
    params: dict[str, str | int | float] = Field(
        default_factory=dict, description="tree parameters as texts, e.g. roll: 90 deg"
    )

    @model_validator(mode="after")
    def _one_kind(self) -> RunItem:
        if (self.tree is None) == (self.route is None):
            raise ValueError("give exactly one of 'tree' and 'route'")
        if self.route is not None and self.params:
            raise ValueError("'params' apply to trees, not to routes")
        return self

    @property
    def label(self) -> str:
        if self.name:
            return self.name
        return Path(str(self.tree or self.route)).name.split(".")[0]


class SeedRange(BaseModel):
    """Seeds ``start .. start + count - 1``."""

    model_config = _STRICT

    start: int = Field(0, ge=0, description="first seed")
    count: int = Field(1, ge=1, le=1_000_000, description="how many seeds")


_Rates = list[Annotated[float, Field(ge=0.0, le=1.0)]]


def _rates(description: str) -> Any:
    return Field(
        default_factory=lambda: [0.0], min_length=1, description=description + " (0..1, a list)"
    )


class LinkAxes(BaseModel):
    """Link byte faults; every combination of the lists runs (a grid)."""

    model_config = _STRICT

    drop: _Rates = _rates("probability a frame is lost")
    corrupt: _Rates = _rates("probability one byte of a frame is changed")
    dup: _Rates = _rates("probability a frame is delivered twice")


def _fault(text: str) -> str:
    from pirate_bt.errors import InputError
    from pirate_bt.sim.faults import parse_fault

    try:
        parse_fault(text)
    except InputError as exc:
        raise ValueError(str(exc)) from None
    return text


_Fault = Annotated[str, AfterValidator(_fault)]


def _one_default() -> list[str | None]:
    return [None]


def _no_faults() -> list[list[_Fault]]:
    return [[]]


class CampaignSpec(BaseModel):
    """A campaign: the matrix, limits and what to keep."""

    model_config = _STRICT

    name: str = Field(description="the campaign's name (report title)")
    description: str = Field("", description="what the campaign shows, for people")
    runs: list[RunItem] = Field(min_length=1, description="trees or routes to run")
    robots: list[str | None] = Field(
        default_factory=_one_default,
        min_length=1,
        description="robot description files (null: the bundled robot)",
    )
    maps: list[str | None] = Field(
        default_factory=_one_default,
        min_length=1,
        description="routes only: simulated truth networks differing from the map"
        " (null: the truth is the map)",
    )
    seeds: SeedRange = Field(default_factory=SeedRange, description="simulator and link seeds")
    link: LinkAxes = Field(default_factory=LinkAxes, description="link fault rates to sweep")
    sim_faults: list[list[_Fault]] = Field(
        default_factory=_no_faults,
        min_length=1,
        description="lists of simulator faults; each list is one point of the axis",
    )
    max_time: str = Field("600 s", description="simulated time limit of one run")
    case_timeout: str = Field("300 s", description="wall-time limit of one case (then killed)")
    rate: str = Field("20 Hz", description="tick rate")
    keep_traces: Literal["failures", "all", "none"] = Field(
        "failures", description="which runs keep a trace: failures (not success), all or none"
    )

    @model_validator(mode="after")
    def _checks(self) -> CampaignSpec:
        for key, dim in (("max_time", "time"), ("case_timeout", "time"), ("rate", "frequency")):
            try:
                value = parse_quantity(getattr(self, key), dim)
            except UnitError as exc:
                raise ValueError(f"{key}: {exc}") from None
            if value <= 0:
                raise ValueError(f"{key} must be positive")
        if any(m is not None for m in self.maps) and any(r.tree for r in self.runs):
            raise ValueError("'maps' (truth differing from the map) apply to routes only")
        return self

    def quantity(self, key: str, dimension: str) -> float:
        """A limit in SI units (``max_time`` → seconds)."""
        return parse_quantity(getattr(self, key), dimension)

    def size(self) -> int:
        """How many cases the matrix expands into."""
        link = len(self.link.drop) * len(self.link.corrupt) * len(self.link.dup)
        return (
            len(self.runs)
            * len(self.robots)
            * len(self.maps)
            * len(self.sim_faults)
            * link
            * self.seeds.count
        )


_CONTEXT: dict[str, Any] = {}


def load_campaign(path: str | Path) -> CampaignSpec:
    """Load and check a campaign file.

    Raises:
        ValidationFailed: the file does not parse or validate (each error located).
    """
    doc = load_yaml(Path(path))
    return validate_document(doc, CampaignSpec, "a campaign", _CONTEXT)


def campaign_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``*.campaign.yaml`` files."""
    schema = CampaignSpec.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "pirate_bt campaign"
    return schema
