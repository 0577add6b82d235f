"""The DTCs that failed last time, for ``beatlog test --lf`` as pytest's ``--lf``.

They are remembered by id in the project's cache folder
(:mod:`beatlog.suite.coverage`), in ``lastfailed.json``. Each run forgets the
DTCs it ran that passed and adds those that failed or could not run; a DTC it did not
run (left out by ``-k``, or after ``-x`` stopped the run) stays as it was. A file that
cannot be read or trusted is ignored with a warning, never a crash.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated

import msgspec

from beatlog.log.limits import MAX_TEXT_LENGTH
from beatlog.suite.coverage import cache_file, read_cached, write_cached
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec

__all__ = ["MAX_REMEMBERED", "last_failed_path", "remember_failed", "rerun_failed"]

MAX_REMEMBERED = 100_000
"""Most failed DTCs remembered."""

_Id = Annotated[str, msgspec.Meta(max_length=MAX_TEXT_LENGTH)]


class _LastFailed(msgspec.Struct, forbid_unknown_fields=True, tag_field="version", tag=1):
    dtcs: Annotated[list[_Id], msgspec.Meta(max_length=MAX_REMEMBERED)]


def last_failed_path(root: Path) -> Path:
    """Where the suite at ``root`` (a spec or a folder of specs) remembers its failures."""
    return cache_file(root, "lastfailed.json")


def _failed(path: Path) -> tuple[list[str], str | None]:
    memory, warning = read_cached(path, _LastFailed, "a beatlog memory of failed DTCs")
    return ([] if memory is None else memory.dtcs), warning


def rerun_failed(specs: Sequence[DtcSpec], path: Path) -> tuple[list[DtcSpec], str]:
    """Of ``specs``, those that failed last time (as remembered at ``path``), and a line
    saying so; all of them when none did, the line saying that too."""
    failed, warning = _failed(path)
    ids = set(failed)
    chosen = [spec for spec in specs if spec.id in ids]
    if chosen:
        count = f"{len(chosen)} DTC{'s' if len(chosen) > 1 else ''}"
        said = f"--lf: rerunning the {count} that failed last time"
    else:
        said = f"--lf: no DTC selected failed last time; running all {len(specs)}"
    return (chosen or list(specs)), said if warning is None else f"{said} ({warning})"


def remember_failed(outcomes: Sequence[SpecOutcome], path: Path) -> str | None:
    """Remember at ``path`` which of ``outcomes`` failed (a verdict other than passed,
    or an audit that found something), forgetting those that passed; the file is written
    only when that changes it. A warning when it cannot be read or written."""
    before, warning = _failed(path)
    ran = {outcome.spec.id for outcome in outcomes}
    failed = {
        outcome.spec.id
        for outcome in outcomes
        if outcome.verdict is not Verdict.PASSED or outcome.audit_findings
    }
    after = [dtc for dtc in before if dtc not in ran or dtc in failed]
    after += sorted(failed - set(after))
    after = [dtc for dtc in after if len(dtc) <= MAX_TEXT_LENGTH][:MAX_REMEMBERED]
    if after == before and warning is None:
        return None
    try:
        write_cached(path, _LastFailed(after))
    except OSError as exc:
        return f"{path}: cannot write: {exc.strerror or exc}; the failures are not remembered"
    return warning
