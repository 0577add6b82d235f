"""DTC specs: one small TOML file per deterministic test case, as the paper prescribes,
read (:func:`load_spec`) and written (:func:`spec_text`, :func:`spec_toml`)::

    name = "avoid-pole"
    purpose = "The rover turns away from a pole in its path."
    procedure = ["Place the rover 1 m before the pole.", "Let it drive for 30 s."]
    log = "avoid-pole.beatlog"             # relative to the spec, or a URL
    system = "myrobot.behaviors:system"    # by default, the log's, where the project lists it

Its optional keys are those of the spec reference; an unknown key is an error naming
the key it may mean. The project's ``[tool.beatlog]`` holds what applies to every spec
(:mod:`beatlog.project.config`), a spec's own coming on top; a spec written for a
failing variant (``variant = N``) replays with its own ``[variants]`` alone. A DTC is
identified as pytest identifies a test: its spec's path from the rootdir, ``::`` and
its name (``robots/dog/dtc/dock.dtc.toml::dock``). A ``module:factory`` (``system``,
``perception``) names a callable that takes no arguments and builds a fresh system (or
perception step) each time it is called, or the object itself when it is not callable.
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
import tomli_w

from beatlog.baseline.file import SPEC_SUFFIX
from beatlog.errors import NotABeatlogError, SpecError
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
from beatlog.replay.compare import Comparison
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.perturbation import Perturbations, declared
from beatlog.suite.remote import Listed, fetched_log, is_url, url_name

__all__ = [
    "SPEC_SUFFIX",
    "DtcSpec",
    "find_rootdir",
    "load_spec",
    "read_spec_data",
    "spec_from_data",
    "spec_text",
    "spec_toml",
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
    """Whether a replay that checks nothing passes; otherwise it is an error of the DTC."""
    comparison: Comparison = field(default_factory=Comparison)
    """What counts as the same when this DTC is judged (renames, ignores, tolerances)."""
    perception: str | None = None
    """The ``module:factory`` of the perception step: replay from the logged samples."""
    migration: StateMigration = field(default_factory=StateMigration)
    """Robot-state fields renamed or retyped since the recording."""
    source: str | None = None
    """For a fleet run's DTC, made from a log alone: the log's path or URL as matched.
    It has no baseline: it is judged against its recording."""
    log_url: str | None = None
    """The URL of the log when it lies behind one; ``log`` is then its file name alone."""
    log_size: int | None = None
    """The size in bytes of the log behind ``log_url`` as a fleet's listing gave it."""
    log_etag: str | None = None
    """The ETag of the log behind ``log_url`` as a fleet's listing gave it."""
    id: str = ""
    """What identifies the DTC (see the module); a fleet log's path or URL. Left out,
    the spec's path as given and its name."""
    named_by_id: bool = False
    """Whether reports name the DTC by its id: another DTC of the run has its name."""
    start_cycle: int = 0
    """The first cycle judged: the cycles before it replay as recorded, unjudged."""
    end_cycle: int | None = None
    """The last cycle judged and read (inclusive); None: the log's last."""
    fresh_start: bool = False
    """Whether the behaviors start from rest at ``start_cycle``, unreplayed before it."""
    invariants: tuple[str, ...] = ()
    """The invariants checked in every cycle: the project's, then the spec's own."""
    perturbations: Perturbations | None = None
    """What its variants perturb; None where it declares no variants."""
    variant_count: int = 0
    """How many variants a run makes of it unless ``--variants`` says otherwise."""
    variant: int | None = None
    """For a variant, its number (from 1); None for the DTC itself."""

    def __post_init__(self) -> None:
        if not self.id:
            object.__setattr__(self, "id", self.source or f"{self.path.as_posix()}::{self.name}")

    @property
    def label(self) -> str:
        """How reports name the DTC: its name, or its id where the name is not enough."""
        return self.id if self.named_by_id else self.name

    @property
    def origin(self) -> str:
        """Where the DTC comes from: its spec file, or a fleet log's path or URL."""
        return str(self.path) if self.source is None else self.source

    @property
    def spec_file(self) -> Path | None:
        """The spec file the DTC's code imports near; None for a fleet log, whose folder
        is never trusted to choose code."""
        return self.path if self.source is None else None

    @property
    def own_spec(self) -> Path:
        """The spec that runs this DTC alone: its own, or for a variant made by a run, the
        one written for it when it fails (:mod:`beatlog.suite.variants`)."""
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
        URL, removed when the block ends (else :class:`~beatlog.errors.RemoteLogError`).
        A spec's own log that is missing raises :class:`~beatlog.errors.NotABeatlogError`
        saying where it was looked for, the slip of a spec moved away from its log."""
        if self.log_url is None:
            if self.spec_file is not None and not self.log.exists():
                raise NotABeatlogError(
                    self.log, "no such file (a spec's log is relative to its folder)"
                )
            return contextlib.nullcontext(self.log)
        return fetched_log(self.log_url, listed=self.listed_log)

    @property
    def listed_log(self) -> Listed | None:
        """What a listing said of the log behind ``log_url``, where it gave both."""
        if self.log_size is None or self.log_etag is None:
            return None
        return Listed(self.log_size, self.log_etag)


def load_spec(path: str | Path, *, rootdir: Path | None = None) -> DtcSpec:
    """Read and validate one spec, its id from ``rootdir`` (by default, the one
    :func:`find_rootdir` finds); problems raise :class:`SpecError` naming file and key."""
    path = Path(path)
    return spec_from_data(path, read_spec_data(path), rootdir=rootdir)


def read_spec_data(path: Path) -> dict[str, Any]:
    """A spec file's TOML, as data, unchecked (:func:`spec_from_data` checks it), or a
    :class:`SpecError`: what tools that write a spec from another start from."""
    text = read_small_text(path, limit=MAX_SPEC_BYTES, kind="DTC spec", error=SpecError)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(path, f"not valid TOML: {exc}") from None


def spec_from_data(path: Path, data: Mapping[str, Any], *, rootdir: Path | None = None) -> DtcSpec:
    """The spec that ``data`` (a spec file's TOML) makes when it lies at ``path``,
    validated as :func:`load_spec` validates a file."""
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
    field_renames = {**project.field_renames, **spec.field_renames}
    for key, own, merged in (
        ("renames", spec.renames, renames),
        ("field_renames", spec.field_renames, field_renames),
    ):
        check_one_to_one(path, key, own)
        check_one_to_one(path, key, merged)
    check_conversions(path, "field_conversions", spec.field_conversions)
    tolerances = {"tolerance": spec.tolerance, "robot_state_tolerance": spec.robot_state_tolerance}
    for key, table in tolerances.items():
        for name, tolerance in table.items():
            if not (math.isfinite(tolerance) and tolerance >= 0):
                problem = f"expected a finite number >= 0, got {tolerance}"
                raise SpecError(path, f"key '{key}.{name}': {problem}")
    # A variant's own spec replays with its own perturbations alone: it reproduces.
    inherited = [] if spec.variant is not None or project.variants is None else [project.variants]
    perturbations, count = declared(
        path, [*inherited, *([] if spec.variants is None else [spec.variants])]
    )
    if perturbations is None and spec.variant is not None:
        perturbations = Perturbations()
    log_url = spec.log if is_url(spec.log) else None
    relative = os.path.relpath(path.resolve(), (rootdir or find_rootdir([path])).resolve())
    return DtcSpec(
        path=path,
        id=f"{Path(relative).as_posix()}::{spec.name}",
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
        migration=StateMigration(
            field_renames, {**project.field_conversions, **spec.field_conversions}
        ),
        start_cycle=spec.start_cycle or 0,
        end_cycle=spec.end_cycle,
        fresh_start=spec.fresh_start,
        perturbations=perturbations,
        variant_count=count,
        variant=spec.variant,
        invariants=tuple(dict.fromkeys([*project.invariants, *spec.invariants])),
    )


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


def spec_text(
    *,
    name: str,
    purpose: str,
    procedure: Iterable[str],
    log: str,
    system: str | None,
    tags: Iterable[str] = (),
    perception: str | None = None,
    invariants: Iterable[str] = (),
    variants: Mapping[str, Any] | None = None,
) -> str:
    """A new spec as TOML text, for tools that write one beside a recording (``beatlog
    import-bag --spec``, a suite's recording script); ``log`` is relative to the spec."""
    return spec_toml(
        {
            "name": name,
            "purpose": purpose,
            "procedure": list(procedure),
            "log": log,
            "system": system,
            "perception": perception,
            "tags": list(tags),
            "invariants": list(invariants) or None,
            "variants": variants,
        }
    )


def spec_toml(data: Mapping[str, Any]) -> str:
    """A spec's data (strings, numbers, booleans, arrays and tables of them, as
    :func:`read_spec_data` reads them) as TOML text: its keys first, then its tables;
    a key of None is left out."""
    return tomli_w.dumps({key: value for key, value in data.items() if value is not None})
