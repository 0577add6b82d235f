"""One rule for approved baselines, wherever a log is judged.

A log is judged against the approved baseline of the spec beside it that names it
(``NAME.dtc.toml`` with ``log = "..."``, and its ``NAME.dtc.expected``), with that
spec's renames, ignores and tolerances, and against its recording otherwise:
``beatlog test SPEC``, ``beatlog replay LOG`` and :func:`beatlog.replay` all follow it,
so none of them fails a DTC another passes. Where several specs beside the log name
it, the one whose ``system`` is the system replayed is its spec.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, NamedTuple

from beatlog.baseline.file import BaselineFile, expected_path, log_digest, read_baseline
from beatlog.errors import BaselineError, SpecError
from beatlog.model.behavior import System
from beatlog.model.setup import SystemFactory
from beatlog.replay.judge import replay as judge
from beatlog.replay.verdict import ReplayResult
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, load_spec, read_spec_data

__all__ = ["Approved", "approved_baseline", "approved_baselines", "approved_for", "replay"]


class Approved(NamedTuple):
    """A log's approved baseline and the spec it belongs to."""

    spec: DtcSpec
    baseline: BaselineFile


def approved_for(baseline: BaselineFile, log: Path, digest: str | None = None) -> BaselineFile:
    """``baseline``, checked to be made from the recording ``log`` (whose SHA-256 is
    ``digest`` where it was taken as the log was read, else taken from the file).

    :raises beatlog.errors.BaselineError: it was approved for another recording.
    """
    if baseline.log_digest != (digest or log_digest(log)):
        raise BaselineError(
            baseline.path, f"approved for another recording than {log.name}; delete it"
        )
    return baseline


def _naming(log: Path) -> list[Path]:
    """The spec files beside ``log`` that name it (a spec that does not parse names
    nothing here; it is an error where it is run)."""
    naming = []
    for spec in sorted(log.parent.glob(f"*{SPEC_SUFFIX}")):
        try:
            named = read_spec_data(spec).get("log")
        except SpecError:
            continue
        if isinstance(named, str) and (spec.parent / named).resolve() == log.resolve():
            naming.append(spec)
    return naming


def _approved(spec_file: Path, log: Path) -> Approved:
    """The spec at ``spec_file`` with its approved baseline, made from ``log``."""
    spec = load_spec(spec_file)
    return Approved(spec, approved_for(read_baseline(expected_path(spec.path)), log))


def approved_baselines(log: str | Path) -> list[Approved]:
    """The approved baselines of every spec beside ``log`` that names it.

    :raises beatlog.errors.BaselineError: one was approved for another recording.
    :raises beatlog.errors.SpecError: a spec that names it is not a valid spec.
    """
    path = Path(log)
    return [_approved(spec, path) for spec in _naming(path) if expected_path(spec).is_file()]


def approved_baseline(log: str | Path, system: object = None) -> Approved | None:
    """The approved baseline of the spec beside ``log`` that names it, if there is one;
    where several name it, of the one whose ``system`` is ``system`` (a ``module:factory``).

    :raises beatlog.errors.BaselineError: as :func:`approved_baselines`, or ``system``
        does not tell which of several specs it is.
    :raises beatlog.errors.SpecError: a spec that names it is not a valid spec.
    """
    path = Path(log)
    naming = _naming(path)
    if not any(expected_path(spec).is_file() for spec in naming):
        return None
    if len(naming) > 1:
        meant = [spec for spec in naming if load_spec(spec).system == system]
        if len(meant) != 1:
            raise BaselineError(
                path,
                f"the specs {', '.join(spec.name for spec in naming)} name it, with approved "
                "baselines, and the system replayed does not tell which: test one of them",
            )
        naming = meant
    return _approved(naming[0], path) if expected_path(naming[0]).is_file() else None


def replay(
    log: str | Path,
    system: System | SystemFactory | str | None = None,
    *,
    approved: bool = True,
    **options: Any,
) -> ReplayResult:
    """Replay ``log`` as :func:`beatlog.replay.judge.replay` does, judged against the
    approved baseline of the spec beside it that names it, with its comparison, unless
    ``baseline`` or ``comparison`` is given or ``approved`` is False; the notes say so.
    """
    found = (
        approved_baseline(log, system)
        if approved and options.get("baseline") is None and options.get("comparison") is None
        else None
    )
    if found is None:
        result = judge(log, system, **options)
        if not approved and approved_baseline(log, system) is not None:  # say so to rerun it
            result = replace(result, reproduce=f"{result.reproduce} --recording")
        return result
    result = judge(
        log,
        system,
        baseline=found.baseline.stream,
        comparison=found.spec.comparison,
        **options,
    )
    note = (
        f"judged against the approved baseline {found.baseline.path.name}, "
        f"as beatlog test {found.spec.path} judges it"
    )
    return replace(result, notes=(note, *result.notes))
