"""DTC specs: one small TOML file per deterministic test case, as the paper prescribes.

A spec names the test case, says what it is for and how it was recorded (the
procedure a person or a scenario script followed), and points at its session log and
the system factory to replay it against::

    name = "avoid-pole"
    purpose = "The rover turns away from a pole in its path."
    procedure = ["Place the rover 1 m before the pole.", "Let it drive for 30 s."]
    log = "avoid-pole.beatlog"            # relative to this file, or a URL
    system = "myrobot.behaviors:system"   # optional: the log's own, where the project lists it
    tags = ["obstacles"]
    allow_truncated = false                 # true: a log cut off by a crash passes
    allow_empty = false                     # true: a replay that checks nothing passes
    renames = { avoid = "avoid_obstacle" }  # behaviors renamed since recording: old = new
    field_renames = { knee_mean = "knee_avg" }  # robot-state fields renamed: old = new
    field_conversions = { battery = "mypkg.compat:percent" }  # retyped: field = converter
    ignore_behaviors = ["blink"]            # their state changes are not compared
    ignore_fields = ["debug_*"]             # output fields not compared (names or globs)
    start_cycle = 4200                      # judge only cycles 4200 to 4380 (inclusive):
    end_cycle = 4380                        # earlier ones rebuild state, later are not read
    fresh_start = true                      # or: behaviors start from rest at start_cycle
    invariants = ["myrobot.invariants:never_stuck"]  # checked in every cycle

    [tolerance]                             # largest accepted difference per output field
    wheel_speed = 1e-9

    [robot_state_tolerance]                 # the same per robot-state field, when the
    heading = 1e-6                          # perception step rebuilds RS_t from samples

    [variants]                              # replay it perturbed too (docs: variants)
    count = 8                               # variants per run, unless --variants says
    heartbeat_jitter = 0.002                # +- seconds on each heartbeat interval
    noise = { battery = 0.05, "pose.x" = 0.01 }  # +- per numeric robot-state field

A spec written for a failing variant (:mod:`beatlog.suite.variants`) has ``variant = N``
too: it replays variant N with its own ``[variants]`` alone (no project default), so
it fails the same way whatever the original spec or the project say later.

``name``, ``purpose``, ``procedure`` and ``log`` are required; every other key is
optional, and a key beatlog does not know is an error (naming the key it may mean).
A DTC is identified as pytest identifies a test, by its id: its spec's path from the
rootdir, ``::`` and its name (``robots/dog/dtc/dock.dtc.toml::dock``), so that two
robots of one repository may each have a ``dock``; reports show the name alone unless
another DTC of the run has it too.
A ``module:factory`` (``system``, ``perception``) names a callable that takes no
arguments and builds a fresh system (or perception step) each time it is called, or
the object itself when it is not callable; it imports from the working directory, the
spec's folder and the spec's project root (the nearest folder above it with a
``pyproject.toml``). A spec without ``system`` replays against the one its log
records only where the project lists it under ``[tool.beatlog] systems``: a log never
chooses code on its own (:mod:`beatlog.project.config`).

A ``log`` that is a URL (``https://host/suite/avoid-pole.beatlog``, ``s3://...``: any
URL fsspec reads, see :mod:`beatlog.suite.remote`) is copied by the process that replays the
DTC, whether here or on a cluster's worker. Specs themselves are local files: their
baselines are written beside them.

The project's ``pyproject.toml`` holds what applies to every spec under ``[tool.beatlog]``
(``renames``, ``field_renames``, ``field_conversions``, ``invariants``, ``variants``:
:mod:`beatlog.project.config`); a spec's own come on top. Robot-state fields renamed or
retyped since the recording are mapped by :mod:`beatlog.replaying.fit.migration` (a
nested field by its dotted path; a conversion is a ``module:function`` imported as
``system`` is); ``invariants`` are ``module:attribute`` references
(:mod:`beatlog.model.invariant`). A window past the log's last cycle is an error.
"""

from __future__ import annotations

import contextlib
import math
import os
import tomllib
from collections.abc import Iterable, Mapping
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import msgspec

from beatlog.baseline.file import SPEC_SUFFIX
from beatlog.errors import SpecError
from beatlog.log.files import project_root, read_small_text
from beatlog.project.config import (
    VariantsConfig,
    check_conversions,
    check_one_to_one,
    check_references,
    dotted_keys,
    explain_validation,
    keys_problem,
    project_config,
    variants_table,
)
from beatlog.replaying.compare import Comparison
from beatlog.replaying.fit.migration import StateMigration
from beatlog.replaying.perturbation import Perturbations, declared
from beatlog.suite.remote import Listed, fetched_log, is_url, url_name

__all__ = [
    "SPEC_SUFFIX",
    "DtcSpec",
    "find_rootdir",
    "load_spec",
    "read_spec_data",
    "spec_from_data",
]

MAX_SPEC_BYTES = 1 << 20
"""A spec is a few lines; anything bigger is not one."""


class _SpecFile(msgspec.Struct, kw_only=True, forbid_unknown_fields=True):
    name: str
    purpose: str
    procedure: list[str]
    log: str
    system: str | None = None
    perception: str | None = None
    tags: list[str] = []
    allow_truncated: bool = False
    allow_empty: bool = False
    renames: dict[str, str] = {}
    field_renames: dict[str, str] = {}
    field_conversions: dict[str, str] = {}
    ignore_behaviors: list[str] = []
    ignore_fields: list[str] = []
    invariants: list[str] = []
    tolerance: dict[str, float] = {}
    robot_state_tolerance: dict[str, float] = {}
    start_cycle: Annotated[int, msgspec.Meta(ge=0)] | None = None
    end_cycle: Annotated[int, msgspec.Meta(ge=0)] | None = None
    fresh_start: bool = False
    variant: Annotated[int, msgspec.Meta(ge=1)] | None = None
    variants: VariantsConfig | None = None


@dataclass(frozen=True)
class DtcSpec:
    """A loaded DTC spec with its log path resolved against the spec's folder, or its
    log's URL."""

    path: Path
    name: str
    purpose: str
    procedure: tuple[str, ...]
    log: Path
    system: str | None
    """The ``module:factory`` of the system under test; None for the one the log records."""
    tags: tuple[str, ...] = ()
    allow_truncated: bool = False
    allow_empty: bool = False
    """Whether a replay that checks nothing (no cycle, or no state change, output, draw
    or sample) is intended, and passes; otherwise it is an error of the DTC."""
    comparison: Comparison = field(default_factory=Comparison)
    """What counts as the same when this DTC is judged (renames, ignores, tolerances)."""
    perception: str | None = None
    """The ``module:factory`` of the perception step: replay from the logged samples."""
    migration: StateMigration = field(default_factory=StateMigration)
    """Robot-state fields renamed or retyped since the recording (the project's and the
    spec's ``field_renames`` and ``field_conversions``)."""
    source: str | None = None
    """For a DTC made from a log alone, with no spec file (a fleet run, see
    :mod:`beatlog.suite.fleet`): the log's path or URL as matched. Such a DTC has no
    baseline; it is judged against its recording."""
    log_url: str | None = None
    """The URL of the log when it lies behind one: the process that replays the DTC
    copies it first, and ``log`` is then the URL's file name alone, no file here."""
    log_size: int | None = None
    """The size in bytes of the log behind ``log_url`` as the listing that found it gave
    it (a fleet run's), so that planning the work asks the storage nothing more; None
    where no listing said."""
    log_etag: str | None = None
    """The ETag of the log behind ``log_url`` as the listing that found it gave it:
    with its size, its copy needs no request but the download, and none where the
    machine's cache holds that object; None where no listing said."""
    id: str = ""
    """What identifies the DTC, as pytest's node id does a test: its spec's path from the
    rootdir, ``::`` and its name (``dtc/dock.dtc.toml::dock``); a fleet log's path or
    URL. Left out, the spec's path as given and its name."""
    named_by_id: bool = False
    """Whether reports name the DTC by its id: another DTC of the run has its name (see
    :func:`~beatlog.suite.discovery.distinguished`)."""
    start_cycle: int = 0
    """The first cycle judged: the cycles before it replay as recorded, unjudged."""
    end_cycle: int | None = None
    """The last cycle judged and read (inclusive); None: the log's last."""
    fresh_start: bool = False
    """Whether the behaviors start from rest at ``start_cycle``, the cycles before it
    not replayed."""
    invariants: tuple[str, ...] = ()
    """The ``module:attribute`` references of the invariants checked in every cycle: the
    project's (``[tool.beatlog] invariants``), then the spec's own."""
    perturbations: Perturbations | None = None
    """What its variants perturb (the project's ``[tool.beatlog.variants]`` and the
    spec's ``[variants]``); None where it declares no variants."""
    variant_count: int = 0
    """How many variants a run makes of it unless ``--variants`` says otherwise."""
    variant: int | None = None
    """For a variant, its number (from 1): replayed with :attr:`perturbations`, judged
    by the behaviors not raising and the invariants; None for the DTC itself."""

    def __post_init__(self) -> None:
        if not self.id:
            default = self.source or f"{self.path.as_posix()}::{self.name}"
            object.__setattr__(self, "id", default)

    @property
    def label(self) -> str:
        """How reports name the DTC: its name, or its id where the name is not enough."""
        return self.id if self.named_by_id else self.name

    @property
    def origin(self) -> str:
        """Where the DTC comes from, as messages name it: its spec file, or a fleet
        log's path or URL."""
        return str(self.path) if self.source is None else self.source

    @property
    def spec_file(self) -> Path | None:
        """The spec file whose folder and project root the DTC's code imports from; None
        for a fleet log, whose folder is never trusted to choose code."""
        return self.path if self.source is None else None

    @property
    def own_spec(self) -> Path:
        """The spec that runs this DTC alone: its own, or for a variant made by a run, the
        one written for it when it fails, ``<stem>.variant-<n>.dtc.toml`` beside its DTC's
        (:mod:`beatlog.suite.variants`)."""
        if self.variant is None or not self.id.endswith(f"[variant-{self.variant}]"):
            return self.path
        stem = self.path.name.removesuffix(SPEC_SUFFIX)
        return self.path.with_name(f"{stem}.variant-{self.variant}{SPEC_SUFFIX}")

    @property
    def log_name(self) -> str:
        """The log as reports name it: its URL, or its path."""
        return str(self.log) if self.log_url is None else self.log_url

    def readable_log(self) -> AbstractContextManager[Path]:
        """The log as a file of this machine: its own, or a copy of the one behind its
        URL, removed when the block ends (:func:`beatlog.suite.remote.fetched_log`).

        :raises beatlog.errors.RemoteLogError: the log behind the URL cannot be copied.
        """
        if self.log_url is None:
            return contextlib.nullcontext(self.log)
        return fetched_log(self.log_url, listed=self.listed_log)

    @property
    def listed_log(self) -> Listed | None:
        """What the listing that found the log behind ``log_url`` said of it, where it
        gave both its size and its ETag."""
        if self.log_size is None or self.log_etag is None:
            return None
        return Listed(self.log_size, self.log_etag)


def load_spec(path: str | Path, *, rootdir: Path | None = None) -> DtcSpec:
    """Read and validate one spec; problems raise :class:`SpecError` naming file and key.
    Its id starts from ``rootdir`` (by default, the one :func:`find_rootdir` finds for
    it)."""
    path = Path(path)
    return spec_from_data(path, read_spec_data(path), rootdir=rootdir)


def read_spec_data(path: Path) -> dict[str, Any]:
    """A spec file's TOML, as data, unchecked (:func:`spec_from_data` checks it): what
    tools that write a spec from another (``beatlog shrink``) start from.

    :raises beatlog.errors.SpecError: it cannot be read, or is not TOML.
    """
    text = read_small_text(path, limit=MAX_SPEC_BYTES, kind="DTC spec", error=SpecError)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(path, f"not valid TOML: {exc}") from None


def spec_from_data(path: Path, data: Mapping[str, Any], *, rootdir: Path | None = None) -> DtcSpec:
    """The spec that ``data`` (a spec file's TOML) makes when it lies at ``path``,
    validated as :func:`load_spec` validates a file; problems raise :class:`SpecError`
    naming ``path`` and the key."""
    data = dict(data)
    if (problem := keys_problem(data, _SpecFile)) is not None:
        raise SpecError(path, problem)
    for key in ("field_renames", "field_conversions"):
        if key in data:
            data[key] = dotted_keys(data[key])
    if "variants" in data:
        data["variants"] = variants_table(data["variants"])
    try:
        spec = msgspec.convert(data, _SpecFile)
    except msgspec.ValidationError as exc:
        raise SpecError(path, explain_validation(str(exc))) from None
    if not spec.name.strip():
        raise SpecError(path, "key 'name': must not be empty")
    if spec.end_cycle is not None and (start := spec.start_cycle or 0) > spec.end_cycle:
        raise SpecError(path, f"key 'start_cycle': {start} is after end_cycle {spec.end_cycle}")
    for key, reference in (("system", spec.system), ("perception", spec.perception)):
        if reference is not None and ":" not in reference:
            raise SpecError(path, f"key {key!r}: expected module:factory, got {reference!r}")
    project = project_config(path.resolve().parent)
    check_references(path, "invariants", spec.invariants)
    renames = {**project.renames, **spec.renames}
    check_one_to_one(path, "renames", spec.renames)
    check_one_to_one(path, "renames", renames)
    field_renames = {**project.field_renames, **spec.field_renames}
    check_one_to_one(path, "field_renames", spec.field_renames)
    check_one_to_one(path, "field_renames", field_renames)
    conversions = {**project.field_conversions, **spec.field_conversions}
    check_conversions(path, "field_conversions", spec.field_conversions)
    for key, tolerances in (
        ("tolerance", spec.tolerance),
        ("robot_state_tolerance", spec.robot_state_tolerance),
    ):
        for name, tolerance in tolerances.items():
            if not (math.isfinite(tolerance) and tolerance >= 0):
                raise SpecError(
                    path, f"key '{key}.{name}': expected a finite number >= 0, got {tolerance}"
                )
    # A variant's own spec replays with its own perturbations alone: it reproduces.
    inherited = [] if spec.variant is not None or project.variants is None else [project.variants]
    perturbations, count = declared(
        path, [*inherited, *([] if spec.variants is None else [spec.variants])]
    )
    log_url = spec.log if is_url(spec.log) else None
    return DtcSpec(
        path=path,
        id=_dtc_id(path, spec.name, find_rootdir([path]) if rootdir is None else rootdir),
        name=spec.name,
        purpose=spec.purpose,
        procedure=tuple(spec.procedure),
        log=path.parent / spec.log if log_url is None else Path(url_name(log_url)),
        log_url=log_url,
        system=spec.system,
        perception=spec.perception,
        tags=tuple(spec.tags),
        allow_truncated=spec.allow_truncated,
        allow_empty=spec.allow_empty,
        comparison=Comparison(
            renames=renames,
            ignore_behaviors=frozenset(spec.ignore_behaviors),
            ignore_fields=tuple(spec.ignore_fields),
            tolerance=spec.tolerance,
            state_tolerance=spec.robot_state_tolerance,
        ),
        migration=StateMigration(field_renames, conversions),
        start_cycle=spec.start_cycle or 0,
        end_cycle=spec.end_cycle,
        fresh_start=spec.fresh_start,
        perturbations=(
            Perturbations() if perturbations is None and spec.variant is not None else perturbations
        ),
        variant_count=count,
        variant=spec.variant,
        invariants=tuple(dict.fromkeys([*project.invariants, *spec.invariants])),
    )


def _dtc_id(path: Path, name: str, rootdir: Path) -> str:
    """The id pytest gives the DTC of the spec at ``path``: its path from ``rootdir``
    (with ``..`` where it lies outside), ``::`` and its name."""
    relative = os.path.relpath(path.resolve(), rootdir.resolve())
    return f"{Path(relative).as_posix()}::{name}"


def find_rootdir(paths: Iterable[str | Path]) -> Path:
    """The folder pytest takes for its rootdir when given ``paths``: the nearest folder
    at or above their common folder that holds a ``pyproject.toml``, else that folder."""
    folders = [
        resolved if resolved.is_dir() else resolved.parent
        for resolved in (Path(path).resolve() for path in paths)
    ]
    if not folders:
        return Path.cwd()
    common = Path(os.path.commonpath(folders))
    return project_root(common) or common
