"""One rule for approved baselines, wherever a log is judged.

A log is judged against the approved baseline of the spec beside it that names it
(``NAME.dtc.toml`` with ``log = "..."``, and its ``NAME.dtc.expected``), with that
spec's renames, ignores and tolerances, and against its recording otherwise:
``beatlog test SPEC``, ``beatlog replay LOG`` and :func:`beatlog.replay` all follow it,
so none of them fails a DTC another passes.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from beatlog.errors import BaselineError
from beatlog.model.behavior import System
from beatlog.replay.judge import replay as judge
from beatlog.replay.verdict import ReplayResult
from beatlog.suite.baseline import Baseline, expected_path, log_digest, read_baseline
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec, load_spec

__all__ = ["Approved", "approved_baseline", "replay"]


@dataclass(frozen=True)
class Approved:
    """A log's approved baseline and the spec it belongs to."""

    spec: DtcSpec
    baseline: Baseline

    @property
    def note(self) -> str:
        """What the verdict was judged against, for the reader."""
        return (
            f"judged against the approved baseline {self.baseline.path.name}, "
            f"as beatlog test {self.spec.path} judges it"
        )


def _names(spec: Path, log: Path) -> bool:
    """Whether the spec file at ``spec`` names ``log`` (a spec that does not parse names
    nothing here; it is an error where it is run)."""
    try:
        named = tomllib.loads(spec.read_text(encoding="utf-8")).get("log")
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return isinstance(named, str) and (spec.parent / named).resolve() == log.resolve()


def approved_baseline(log: str | Path) -> Approved | None:
    """The approved baseline of the spec beside ``log`` that names it, if there is one.

    :raises beatlog.errors.BaselineError: the baseline was approved for another
        recording, or two specs beside the log name it and have approved baselines.
    :raises beatlog.errors.SpecError: the spec that names it is not a valid spec.
    """
    path = Path(log)
    specs = [
        spec
        for spec in sorted(path.parent.glob(f"*{SPEC_SUFFIX}"))
        if expected_path(spec).is_file() and _names(spec, path)
    ]
    if not specs:
        return None
    if len(specs) > 1:
        named = ", ".join(spec.name for spec in specs)
        raise BaselineError(
            path, f"the specs {named} name it, each with an approved baseline: test one of them"
        )
    spec = load_spec(specs[0])
    baseline = read_baseline(expected_path(spec.path))
    if baseline.log_digest != log_digest(path):
        raise BaselineError(
            baseline.path, f"approved for another recording than {path.name}; delete it"
        )
    return Approved(spec, baseline)


def replay(
    log: str | Path,
    system: System | str | None = None,
    *,
    approved: bool = True,
    **options: Any,
) -> ReplayResult:
    """Replay ``log`` as :func:`beatlog.replay.judge.replay` does (the same options), and
    judge it against the approved baseline of the spec beside it that names it, with
    that spec's comparison, when there is one and neither ``expected`` nor
    ``comparison`` is given; ``approved=False`` judges against the recording. The
    result's notes say which baseline was used.
    """
    found = (
        approved_baseline(log)
        if approved and options.get("expected") is None and options.get("comparison") is None
        else None
    )
    if found is None:
        result = judge(log, system, **options)
        if not approved and approved_baseline(log) is not None:  # say so to rerun it
            result = replace(result, reproduce=f"{result.reproduce} --recording")
        return result
    result = judge(
        log,
        system,
        expected=found.baseline.expectation,
        comparison=found.spec.comparison,
        **options,
    )
    return replace(result, notes=(found.note, *result.notes))
