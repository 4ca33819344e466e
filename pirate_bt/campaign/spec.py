"""The campaign file (``*.campaign.yaml``): a matrix of what to run, many times.

A campaign is the cross product of its axes::

    runs      what runs: a tree with parameters in a network, a route, or a
              navigator with parameters in a network
    robots    robot descriptions (``null``: the bundled robot)
    maps      the simulated truth each route runs in (``null``: truth = the map)
    as_built  or as-built variants of each run's map as the truth ``{count, first, scale}``
    link      link byte faults, each key a list of rates (a grid): drop, corrupt, dup
    sim_faults lists of simulator faults (``KIND[:TARGET]@AT[+DURATION]``)
    seeds     a range ``{start, count}``

Every combination except the seed and the as-built variant is a *group*; the
report gives one row per group. The order of expansion is fixed (runs, robots,
maps, sim faults, link grid, as-built variants, seeds), so case ids are the same
wherever the campaign runs.

A spec comes from a file (:func:`load_campaign`) or from plain data
(:func:`campaign_from_data`). Either way its size is bounded before anything is
built: the file's bytes (:data:`MAX_SPEC_BYTES`), every text and list (the
``MAX_*`` constants below, checked by the model) and, in
:func:`pirate_bt.campaign.cases.check_size`, the number of cases the matrix
expands to, counted without expanding it. :func:`spec_source` tells where a
spec came from, so later checks can point at ``file:line:column``.
"""

from __future__ import annotations

import os
import unicodedata
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    StringConstraints,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from pirate_bt.api.options import MAX_RATE_HZ, MAX_SEED, MAX_TIME_S
from pirate_bt.campaign.plain import plain
from pirate_bt.campaign.source import SpecSource, remember, spec_source
from pirate_bt.errors import InputError, LocatedError, SourceLocation, UnitError, ValidationFailed
from pirate_bt.units import parse_quantity
from pirate_bt.yamlfile import load_yaml
from pirate_bt.yamlvalidate import validate_document, validation_problems

__all__ = [
    "MAX_AXIS",
    "MAX_CASE_TIMEOUT_S",
    "MAX_FAULTS",
    "MAX_FILE_NAME",
    "MAX_LABEL",
    "MAX_NAME",
    "MAX_PARAMS",
    "MAX_RATE_HZ",
    "MAX_SEED",
    "MAX_SPEC_BYTES",
    "MAX_TIME_S",
    "AsBuiltAxis",
    "CampaignSpec",
    "LinkAxes",
    "RunItem",
    "SeedRange",
    "SpecSource",
    "campaign_from_data",
    "campaign_schema",
    "load_campaign",
    "spec_source",
]

_STRICT = ConfigDict(extra="forbid", frozen=True)

MAX_SPEC_BYTES = 1_000_000
"""The largest campaign file read (the shipped ones are under 1 kB)."""
MAX_AXIS = 1_000
"""The most entries of one axis list (runs, robots, maps, sim_faults, each link rate list)."""
MAX_FAULTS = 64
"""The most simulator faults in one point of the ``sim_faults`` axis."""
MAX_PARAMS = 64
"""The most parameters of one run."""
MAX_NAME = 100
"""The longest campaign name (it names the default output folder, ``campaign-NAME``)."""
MAX_LABEL = 200
"""The longest run name, parameter value or fault text."""
MAX_FILE_NAME = 4096
"""The longest file reference (a tree, route, network or robot): PATH_MAX on Linux."""
MAX_CASE_TIMEOUT_S = 7 * 24 * 3600.0
"""The longest wall-time limit of one case (a week); a case is killed after it."""

_LIMITS = {
    "max_time": ("time", MAX_TIME_S, "s"),
    "case_timeout": ("time", MAX_CASE_TIMEOUT_S, "s"),
    "rate": ("frequency", MAX_RATE_HZ, "Hz"),
}

# MAX_TIME_S (the longest simulated-time limit of one run, 1e9 s) and MAX_SEED (the
# largest seed, 2**63 - 1) are the API's (pirate_bt.api.options), re-exported: a
# campaign's case is an API call, so a spec takes what that call takes. Every seed a
# range expands to (start + count - 1) must be one (checked by SeedRange), so a
# campaign never reaches a case the simulator refuses. 2**63 - 1 is the largest
# signed 64-bit integer: seeds stay exact in the report's JSON and CSV for Python,
# pandas and any int64 reader (a JavaScript number is exact only to 2**53).


def _printable(text: str) -> str:
    """Text a terminal and the report show as written: no control character (C0, DEL
    and, since 2026-12-01, C1: U+009B is an ESC [ to many terminals), no invisible or
    text-direction one (a zero-width space, U+202E, which reversed a name shown)."""
    if text.isprintable():
        return text
    for c in text:
        category = unicodedata.category(c)
        if category == "Cc":
            raise ValueError("control characters (NUL, newline, tab, ...) are not allowed here")
        if category == "Cf":
            raise ValueError(
                f"U+{ord(c):04X} {unicodedata.name(c, '')} (an invisible character) is not"
                " allowed here"
            )
    return text


def _campaign_name(text: str) -> str:
    _printable(text)
    if "/" in text or "\\" in text:
        raise ValueError("not a path: the campaign's name may not hold '/' or '\\'")
    return text


_Name = Annotated[
    str, StringConstraints(min_length=1, max_length=MAX_NAME), AfterValidator(_campaign_name)
]
_Label = Annotated[str, StringConstraints(max_length=MAX_LABEL), AfterValidator(_printable)]
_FileName = Annotated[
    str, StringConstraints(min_length=1, max_length=MAX_FILE_NAME), AfterValidator(_printable)
]
_Quantity = Annotated[str, StringConstraints(max_length=64)]
_ParamKey = Annotated[str, StringConstraints(min_length=1, max_length=MAX_LABEL)]


def _short(value: str | bool | int | float) -> str | bool | int | float:
    # After the union, so that a long text is refused as text (not read as a number).
    if isinstance(value, str) and len(value) > MAX_LABEL:
        raise ValueError(f"a parameter has at most {MAX_LABEL} characters, not {len(value):,}")
    return value


# bool before int: YAML's true is a boolean parameter's value, not the number 1 (it
# was read as 1, so `distance: true` was refused as "'1' needs a unit").
_ParamValue = Annotated[str | bool | int | float, AfterValidator(_short)]


class RunItem(BaseModel):
    """One thing to run: a PAB or other tree in a network, a route, or a navigator.

    Exactly one of ``tree``, ``route`` and ``navigator`` is given. A navigator
    (:func:`pirate_bt.navigate`) runs in ``network`` (default ``straight``), which is
    also its map unless ``blind`` is true; the ``maps`` axis makes the simulated
    truth differ from that map, as for routes.
    """

    model_config = _STRICT

    name: _Label | None = Field(None, description="label in the report (default: the file's stem)")
    tree: _FileName | None = Field(None, description="a behaviour tree file or bundled name")
    route: _FileName | None = Field(None, description="a route file (.route) or bundled name")
    navigator: _Label | None = Field(
        None,
        description="a navigator by name (route, goal, or one an installed package"
        " registers), made with 'params'",
    )
    network: _FileName | None = Field(
        None,
        description="the pipe network (tree: the simulated world, default straight;"
        " route: the map, default the route's own network; navigator: the map and,"
        " unless 'maps' says otherwise, the world, default straight)",
    )
    params: dict[_ParamKey, _ParamValue] = Field(
        default_factory=dict,
        max_length=MAX_PARAMS,
        description="tree or navigator parameters as texts, e.g. roll: 90 deg",
    )
    blind: bool = Field(
        False,
        description="navigators only: run without a map (the network is only the"
        " simulated world; the belief is the odometry's)",
    )

    @model_validator(mode="after")
    def _one_kind(self) -> RunItem:
        given = [k for k in ("tree", "route", "navigator") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of 'tree', 'route' and 'navigator'")
        if self.route is not None and self.params:
            raise ValueError("'params' apply to trees and navigators, not to routes")
        if self.blind and self.navigator is None:
            raise ValueError("'blind' applies to navigators only")
        return self

    @property
    def label(self) -> str:
        if self.name:
            return self.name
        return self.navigator or Path(str(self.tree or self.route)).name.split(".")[0]

    @property
    def label_key(self) -> str:
        """The key the run's :attr:`label` comes from: ``name``, else its kind's."""
        if self.name:
            return "name"
        return "navigator" if self.navigator else "tree" if self.tree else "route"


class SeedRange(BaseModel):
    """Seeds ``start .. start + count - 1``, each at most :data:`MAX_SEED`."""

    model_config = _STRICT

    start: int = Field(0, ge=0, le=MAX_SEED, strict=True, description="first seed")
    count: int = Field(
        1,
        ge=1,
        le=MAX_SEED,
        strict=True,
        description="how many seeds (a range: the campaign's max_cases bounds the expansion)",
    )

    @model_validator(mode="after")
    def _last_seed(self) -> SeedRange:
        if self.start + self.count - 1 > MAX_SEED:
            raise ValueError(
                f"the last seed, start + count - 1, must be at most 2**63 - 1 (the largest"
                f" seed a run takes); at most {MAX_SEED - self.start + 1} seeds from this start"
            )
        return self


class AsBuiltAxis(BaseModel):
    """As-built variants of each run's map as the simulated truth (routes and navigators).

    Variant ``first .. first + count - 1`` of :func:`pirate_bt.pipes.asbuilt.perturb_network`
    with the stated bounds times ``scale``: every run meets the same variants.
    """

    model_config = _STRICT

    count: int = Field(ge=1, le=MAX_AXIS, strict=True, description="how many variants")
    first: int = Field(1, ge=0, le=MAX_SEED, strict=True, description="the first variant's seed")
    scale: float = Field(
        1.0,
        gt=0.0,
        le=10.0,
        allow_inf_nan=False,
        description="times the stated as-built bounds (2: twice as wide)",
    )

    @model_validator(mode="after")
    def _last_variant(self) -> AsBuiltAxis:
        if self.first + self.count - 1 > MAX_SEED:
            raise ValueError(
                "the last variant's seed, first + count - 1, must be at most 2**63 - 1"
            )
        return self


# allow_inf_nan=False: a NaN rate was refused as "less than or equal to 1"
def _no_bool(value: Any, info: ValidationInfo) -> Any:
    if isinstance(value, bool):  # true/yes/on was a rate of 1: every frame lost
        name = f"{info.field_name}: " if info.field_name else ""
        raise ValueError(f"{name}should be a rate from 0 to 1, not {str(value).lower()}")
    return value


_Rates = list[
    Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False), BeforeValidator(_no_bool)]
]
"""Numbers (YAML reads ``1e-1`` as text: taken as the number it writes), never true."""


def _rates(description: str) -> Any:
    return Field(
        default_factory=lambda: [0.0],
        min_length=1,
        max_length=MAX_AXIS,
        description=description + " (0..1, a list)",
    )


class LinkAxes(BaseModel):
    """Link byte faults; every combination of the lists runs (a grid)."""

    model_config = _STRICT

    drop: _Rates = _rates("probability a frame is lost")
    corrupt: _Rates = _rates("probability one byte of a frame is changed")
    dup: _Rates = _rates("probability a frame is delivered twice")


def _fault(text: str) -> str:
    from pirate_bt.sim.faults import parse_fault

    try:
        parse_fault(text, option="")  # located at its place in the spec
    except InputError as exc:
        raise ValueError(str(exc)) from None
    return text


_Fault = Annotated[str, StringConstraints(max_length=MAX_LABEL), AfterValidator(_fault)]


def _one_default() -> list[_FileName | None]:
    return [None]


def _no_faults() -> list[list[_Fault]]:
    return [[]]


class CampaignSpec(BaseModel):
    """A campaign: the matrix, limits and what to keep."""

    model_config = _STRICT

    name: _Name = Field(
        description="the campaign's name (report title, default output folder campaign-NAME):"
        " no '/', '\\' or control characters"
    )
    description: str = Field(
        "", max_length=10_000, description="what the campaign shows, for people"
    )
    runs: list[RunItem] = Field(
        min_length=1, max_length=MAX_AXIS, description="trees, routes or navigators to run"
    )
    robots: list[_FileName | None] = Field(
        default_factory=_one_default,
        min_length=1,
        max_length=MAX_AXIS,
        description="robot description files (null: the bundled robot)",
    )
    maps: list[_FileName | None] = Field(
        default_factory=_one_default,
        min_length=1,
        max_length=MAX_AXIS,
        description="routes and navigators: simulated truth networks differing from"
        " the map"
        " (null: the truth is the map)",
    )
    as_built: AsBuiltAxis | None = Field(
        None,
        description="routes and navigators: as-built variants of the map (a blind"
        " navigator's network) as the simulated truth (instead of 'maps')",
    )
    seeds: SeedRange = Field(default_factory=SeedRange, description="simulator and link seeds")
    link: LinkAxes = Field(default_factory=LinkAxes, description="link fault rates to sweep")
    sim_faults: list[Annotated[list[_Fault], Field(max_length=MAX_FAULTS)]] = Field(
        default_factory=_no_faults,
        min_length=1,
        max_length=MAX_AXIS,
        description="lists of simulator faults; each list is one point of the axis",
    )
    max_time: _Quantity = Field("600 s", description="simulated time limit of one run")
    case_timeout: _Quantity = Field(
        "300 s", description="wall-time limit of one case (then killed)"
    )
    rate: _Quantity = Field("20 Hz", description="tick rate")
    keep_traces: Literal["failures", "all", "none"] = Field(
        "failures", description="which runs keep a trace: failures (not success), all or none"
    )

    @model_validator(mode="after")
    def _cross(self, info: ValidationInfo) -> CampaignSpec:
        context = info.context if isinstance(info.context, dict) else {}
        problems = self.cross_check()
        if problems and not context.get("defer_cross_checks"):
            raise ValueError("; ".join(message for _path, message, _first in problems))
        return self

    def cross_check(self) -> list[tuple[tuple[str | int, ...], str, tuple[str | int, ...]]]:
        """Rules that span the runs, each as ``(path, message, path of the first)``.

        Two runs of one name: the report tells groups apart by a run's name (its label),
        so they would be counted as one group. Each is placed at the later run's name,
        or at the key its name comes from (its tree, route or navigator), not at
        ``runs:``.
        """
        first: dict[str, int] = {}
        out: list[tuple[tuple[str | int, ...], str, tuple[str | int, ...]]] = []
        for i, run in enumerate(self.runs):
            j = first.setdefault(run.label, i)
            if j != i:
                out.append(
                    (
                        ("runs", i, run.label_key),
                        f"runs[{j}] and runs[{i}] are both named {run.label!r}: give each run"
                        " a 'name' of its own (the report's groups are told apart by it)",
                        ("runs", j, self.runs[j].label_key),
                    )
                )
        return out

    @field_validator(*_LIMITS, mode="before")
    @classmethod
    def _limit_text(cls, value: Any, info: ValidationInfo) -> Any:
        # "Input should be a valid string" said nothing of what to write (max_time: 600)
        if isinstance(value, str):
            return value
        key = str(info.field_name)
        dimension = _LIMITS[key][0]
        example = cls.model_fields[key].default
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        shown = repr(value) if number or isinstance(value, bool) else f"a {type(value).__name__}"
        shown = "null" if value is None else shown
        shown = shown if len(shown) <= 40 else f"a number of {len(shown)} characters"
        alone = " (a number alone has no unit)" if number else ""
        raise ValueError(
            f"{key}: give a {dimension} with its unit, e.g. {example!r}, not {shown}{alone}"
        )

    @field_validator(*_LIMITS)
    @classmethod
    def _limits(cls, text: str, info: ValidationInfo) -> str:
        # a field validator, so that a bad limit is placed at its own key in the file
        key = str(info.field_name)
        dimension, most, unit = _LIMITS[key]
        try:
            value = parse_quantity(text, dimension)
        except UnitError as exc:
            raise ValueError(f"{key}: {exc}") from None
        if not value > 0:
            raise ValueError(f"{key} must be positive")
        if value > most:
            raise ValueError(f"{key} is at most {most:g} {unit}, not {text!r}")
        limit = info.data.get("max_time") if key == "rate" else None
        if limit is not None and 1.0 / value > parse_quantity(limit, "time"):
            # as `pirate-bt run` refuses it; every case was an error row
            raise ValueError(
                f"rate {text!r}: no tick would come within max_time ({limit}):"
                " a tick period must be at most the time limit"
            )
        return text

    @field_validator("maps", "as_built")
    @classmethod
    def _truths(cls, value: Any, info: ValidationInfo) -> Any:
        # at its own key, naming a tree run (it was the file's 1:1, as the model's check)
        given = value is not None if info.field_name == "as_built" else any(value)
        trees = [r.label for r in info.data.get("runs", []) if r.tree]
        if given and trees:
            what = "'maps' (truth differing from the map) apply"
            if info.field_name == "as_built":
                what = "'as_built' (variants of the network) applies"
            raise ValueError(f"{what} to routes and navigators only; run {trees[0]!r} is a tree")
        if given and info.field_name == "as_built" and any(info.data.get("maps", [])):
            raise ValueError("give 'as_built' or 'maps', not both")
        return value

    def quantity(self, key: str, dimension: str) -> float:
        """A limit in SI units (``max_time`` → seconds)."""
        return parse_quantity(getattr(self, key), dimension)

    def axes(self) -> list[tuple[tuple[str, ...], int]]:
        """Each axis of the matrix as ``(its key path in the file, its length)``.

        The seed axis counts its range (``seeds.count``): nothing is expanded.
        """
        return [
            (("runs",), len(self.runs)),
            (("robots",), len(self.robots)),
            (("maps",), len(self.maps)),
            (("as_built", "count"), self.as_built.count if self.as_built is not None else 1),
            (("sim_faults",), len(self.sim_faults)),
            (("link", "drop"), len(self.link.drop)),
            (("link", "corrupt"), len(self.link.corrupt)),
            (("link", "dup"), len(self.link.dup)),
            (("seeds", "count"), self.seeds.count),
        ]

    def size(self) -> int:
        """How many cases the matrix expands into (the product of the axes, computed)."""
        total = 1
        for _path, length in self.axes():
            total *= length
        return total


_CONTEXT: dict[str, Any] = {"defer_cross_checks": True}
"""Rules spanning the runs (:meth:`CampaignSpec.cross_check`) are said where they
are written: after validation, by the loaders."""


def load_campaign(path: str | Path) -> CampaignSpec:
    """Load and check a campaign file.

    A file larger than :data:`MAX_SPEC_BYTES` is refused before it is read.

    Raises:
        ValidationFailed: the file does not parse or validate (each error located).
    """
    p = Path(path)
    try:
        size = p.stat().st_size if p.is_file() else 0
    except (OSError, ValueError):
        size = 0  # load_yaml words the problem
    if size > MAX_SPEC_BYTES:
        raise ValidationFailed(
            [
                LocatedError(
                    f"the file has {size:,} bytes, more than the {MAX_SPEC_BYTES:,}"
                    " a campaign file may have",
                    SourceLocation(str(path)),
                )
            ]
        )
    doc = load_yaml(p)
    spec = validate_document(doc, CampaignSpec, "a campaign", _CONTEXT)
    return remember(spec, SpecSource(str(path), p.parent, doc.locator))


def campaign_from_data(
    data: Mapping[str, Any],
    *,
    base: str | os.PathLike[str] | None = None,
    name: str = "campaign spec",
) -> CampaignSpec:
    """Check plain data (a mapping, as a campaign file loads) as a campaign.

    Args:
        data: The campaign, as YAML would load it.
        base: The folder relative file names resolve against first (default: the
            working folder; then the bundled files, as for a file).
        name: What error messages call the spec.

    Raises:
        InputError: the data does not validate; one line per problem, each
            naming its key (``campaign spec: runs[0].tree: ...``).
    """
    source = SpecSource(name, Path(base) if base is not None else Path("."))
    if not isinstance(data, Mapping):
        raise source.error((), "a campaign must be a mapping of keys")
    data = plain(data, name)  # a NumPy count, a Path: as the YAML would say them (plain.py)
    try:
        spec = CampaignSpec.model_validate(dict(data), context=_CONTEXT)
    except ValidationError as exc:
        raise source.errors(validation_problems(exc, dict(data), CampaignSpec)) from None
    problems = spec.cross_check()
    if problems:  # the message names the first run: no file place to add
        raise source.errors([(path, message) for path, message, _first in problems])
    return remember(spec, source)


def campaign_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``*.campaign.yaml`` files."""
    schema = CampaignSpec.model_json_schema(mode="validation")
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "pirate_bt campaign"
    return schema
