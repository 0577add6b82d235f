"""A suite that lives: the dog's intended changes kept without re-recording.

Each of the dog's intended changes (``beatlog_examples.dog.history.CHANGES``) is applied
to a copy of the dog, alone and then all together, and the committed 22-DTC suite is
taken through what a team does: ``beatlog test`` (how many DTCs notice the change),
``beatlog test --update`` and approve (every failure re-baselined, none refused: no
new recording), ``beatlog test`` again (all pass), then a bug is planted on top
(``PLANTED_BUG``) and the suite must fail. Baselines are measured against their logs.

The CPU columns are the CPU time of replaying the re-baselined suite against the
changed dog, one job, in this process, medians of three alternated rounds, over two
others: the committed suite against the dog as recorded (what matching draws and the
approved robot states cost, beside whatever the change itself costs the behaviors), and
the suite as if re-recorded (what matching draws and the baselines alone cost): each
log written anew from the re-baselined replay's own cycles (heartbeats, samples, the
robot states perception rebuilt, the draws made, state changes and outputs), as a new recording
would hold them had the world answered as recorded, and replayed strictly, with no
baseline.

Run it as ``python bench/bench_intended_changes.py [--json FILE]``; about seven minutes on 2
cores. Nothing here asserts anything: it reports.

For instruction counts, ``--passes rebaselined|rerecorded --times N`` re-baselines the
suite for all seven changes (or ``--change N`` alone) and re-records it as above, then
replays the 22 DTCs (``beatlog.replay`` with each one's approved baseline, or strictly
the re-recorded logs) once each way as a warm-up and N more times the way named: under
``PYTHONHASHSEED=0 valgrind --tool=cachegrind --cache-sim=no``, the difference of the
``I refs`` counts of N = 1 and N = 0 is one pass, the set-up left out. ``--prepared DIR``
prepares the two suites in DIR once and reuses them in later runs (and across trees, to
compare them on the same baselines).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import msgspec
from rich.console import Console
from rich.table import Table

from beatlog.baseline.file import expected_path, read_baseline
from beatlog.baseline.policy import UpdateMode
from beatlog.log.format import SessionEnd
from beatlog.log.reader import SessionLogReader
from beatlog.log.writer import SessionLogWriter
from beatlog.project.usercode import load_system
from beatlog.replay.core import CycleOutcome
from beatlog.replay.judge import replay
from beatlog.suite.discovery import discover_specs
from beatlog.suite.maintenance import UpdateAction, approve, update_baselines
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict
from beatlog.suite.spec import DtcSpec
from beatlog_examples.dog import SUITE_DIR
from beatlog_examples.dog.history import CHANGES, PLANTED_BUG, Change, changed_dog

_STEPS = 0


def _specs(folder: Path, suite: Path, changes: Sequence[Change]) -> list[DtcSpec]:
    """The suite's specs pointed at a dog with ``changes`` applied (a package of its own)."""
    global _STEPS  # noqa: PLW0603 - one package name per step, in one process
    _STEPS += 1
    system = changed_dog(folder, f"dog_changed_{_STEPS}", changes)
    package = system.partition(":")[0]
    for spec in SUITE_DIR.glob("*.dtc.toml"):
        text = spec.read_text(encoding="utf-8")
        text = text.replace("beatlog_examples.dog:system", system)
        text = text.replace("beatlog_examples.dog.perception", f"{package}.perception")
        (suite / spec.name).write_text(text, encoding="utf-8")
    return discover_specs([suite])


def _rerecorded(spec: DtcSpec, folder: Path) -> DtcSpec:
    """``spec`` with a log of what its re-baselined replay did, as a new recording of
    the changed dog would hold it, and no baseline (see the docstring)."""
    assert spec.system is not None
    system = load_system(spec.system)
    with SessionLogReader(spec.log) as reader:
        header = msgspec.structs.replace(
            reader.header,
            behaviors=list(system.behaviors),
            initial_states=[behavior.state for behavior in system.behaviors.values()],
        )
    log = folder / spec.log.name
    writer = SessionLogWriter(log, header)

    def keep(outcome: CycleOutcome) -> None:
        record = outcome.record
        writer.append(
            record.heartbeat_ns,
            outcome.state,
            outcome.changes or [],
            list(outcome.drawn),
            dict(outcome.outputs),
            record.samples,
        )

    expected = expected_path(spec.path)
    result = replay(
        spec.log,
        system,
        baseline=read_baseline(expected).whole if expected.exists() else None,
        comparison=spec.comparison,
        perception=spec.perception,
        observe=keep,
        explain=False,
        migration=spec.migration,
    )
    assert result.ok, result.divergence
    writer.close(SessionEnd(cycles=result.cycles, robot_time_ns=result.robot_time_ns))
    copy = folder / spec.path.name
    copy.write_text(spec.path.read_text(encoding="utf-8"), encoding="utf-8")
    return dataclasses.replace(spec, path=copy, log=log)


def _failed(outcomes: list[SpecOutcome]) -> int:
    return sum(o.verdict is not Verdict.PASSED for o in outcomes)


def _cpu(specs: list[DtcSpec]) -> float:
    """CPU seconds of this process replaying ``specs`` on one job."""
    started = time.process_time()
    outcomes = run_suite(specs, jobs=1)
    assert _failed(outcomes) == 0
    return time.process_time() - started


def _history(folder: Path, title: str, changes: Sequence[Change], jobs: int) -> dict[str, Any]:
    """Take a fresh copy of the suite through ``changes``, re-baselined, then a planted bug."""
    suite = folder / f"suite-{_STEPS + 1}"
    suite.mkdir()
    for log in SUITE_DIR.glob("*.beatlog"):
        shutil.copy(log, suite)
    specs = _specs(folder, suite, changes)
    before = run_suite(specs, jobs=jobs, update=UpdateMode.NEW)
    updates = update_baselines(before, UpdateMode.NEW)
    refused = [u.reason for u in updates if u.action is UpdateAction.REFUSED]
    if any(u.action is UpdateAction.WRITTEN for u in updates):
        approve([suite])
    after = run_suite(specs, jobs=jobs)
    original = discover_specs([SUITE_DIR])
    again = suite.with_name(suite.name + "-rerecorded")
    again.mkdir()
    rerecorded = [_rerecorded(spec, again) for spec in specs]
    rounds = [(_cpu(original), _cpu(specs), _cpu(rerecorded)) for _ in range(3)]  # alternated
    planted = run_suite(_specs(folder, suite, [*changes, PLANTED_BUG]), jobs=jobs)
    baselines = sum(p.stat().st_size for p in suite.glob("*.dtc.expected"))
    logs = sum(p.stat().st_size for p in suite.glob("*.beatlog"))
    open_loop = sum(1 for o in before if o.update is not None and o.update.open_loop is not None)
    return {
        "change": title,
        "noticed": _failed(before),
        "kept": len(updates) - len(refused) if _failed(before) else 0,
        "refused": refused,
        "failing_after": _failed(after),
        "open_loop": open_loop,
        "planted_bug_caught": _failed(planted),
        "baseline_bytes": baselines,
        "log_bytes": logs,
        "cpu_recorded_s": statistics.median(before for before, _, _ in rounds),
        "cpu_rebaselined_s": statistics.median(after for _, after, _ in rounds),
        "cpu_rerecorded_s": statistics.median(again for _, _, again in rounds),
    }


def _prepare(folder: Path, changes: Sequence[Change]) -> None:
    """Re-baseline the suite for ``changes`` in ``folder`` and re-record it."""
    suite = folder / "suite"
    suite.mkdir()
    for log in SUITE_DIR.glob("*.beatlog"):
        shutil.copy(log, suite)
    specs = _specs(folder, suite, changes)
    update_baselines(run_suite(specs, jobs=1, update=UpdateMode.NEW), UpdateMode.NEW)
    approve([suite])
    again = folder / "again"
    again.mkdir()
    for spec in specs:
        _rerecorded(spec, again)


def _passes(rerecorded: bool, times: int, changes: Sequence[Change], prepared: Path | None) -> None:
    """Re-baseline the suite for ``changes`` and re-record it (or take what ``prepared``
    holds from an earlier run, preparing it where it is empty), then replay it a warm-up
    and ``times`` more passes, re-baselined or as re-recorded (see the docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) if prepared is None else prepared.resolve()
        sys.path.insert(0, str(folder))
        if not (folder / "again").is_dir():
            folder.mkdir(parents=True, exist_ok=True)
            _prepare(folder, changes)
        specs = discover_specs([folder / "suite"])
        copies = discover_specs([folder / "again"])

        def one_pass(which: list[DtcSpec]) -> None:
            for spec in which:
                expected = expected_path(spec.path)
                baseline = read_baseline(expected).whole if expected.exists() else None
                result = replay(
                    spec.log, spec.system, baseline=baseline, perception=spec.perception
                )
                assert result.ok, result.divergence

        one_pass(specs)
        one_pass(copies)
        for _ in range(times):
            one_pass(copies if rerecorded else specs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    parser.add_argument("--jobs", type=int, default=2, help="replay jobs (default 2)")
    parser.add_argument("--passes", choices=("rebaselined", "rerecorded"))
    parser.add_argument("--times", type=int, default=1, help="passes after the warm-up")
    parser.add_argument(
        "--prepared",
        type=Path,
        help="with --passes: a folder to prepare the suites in once, then reuse",
    )
    parser.add_argument(
        "--change",
        type=int,
        choices=range(1, len(CHANGES) + 1),
        help="with --passes: only this one of the changes (1 to 7), not all seven",
    )
    args = parser.parse_args()
    if args.passes:
        changes = CHANGES if args.change is None else [CHANGES[args.change - 1]]
        _passes(args.passes == "rerecorded", args.times, changes, args.prepared)
        return
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sys.path.insert(0, str(folder))
        for change in CHANGES:
            rows.append(_history(folder, change.title, [change], args.jobs))
        rows.append(_history(folder, "all seven together", CHANGES, args.jobs))
    table = Table(title="the dog's intended changes, each kept by re-baselining (22 DTCs)")
    columns = (
        "change",
        "noticed",
        "kept",
        "after",
        "open loop",
        "bug caught",
        "baselines",
        "CPU / recorded",
        "CPU / re-recorded",
    )
    for column in columns:
        table.add_column(column, justify="left" if column == "change" else "right")
    for row in rows:
        share = row["baseline_bytes"] / row["log_bytes"]
        table.add_row(
            row["change"],
            str(row["noticed"]),
            str(row["kept"]),
            f"{row['failing_after']} failing",
            str(row["open_loop"]),
            f"{row['planted_bug_caught']} DTCs",
            f"{row['baseline_bytes'] / 1e3:,.1f} kB ({share:.1%} of logs)",
            f"{row['cpu_rebaselined_s'] / row['cpu_recorded_s']:.2f}",
            f"{row['cpu_rebaselined_s'] / row['cpu_rerecorded_s']:.2f}",
        )
    Console().print(table)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
