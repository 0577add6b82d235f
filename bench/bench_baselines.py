"""What baselines cost next to their logs: the dog's suite re-baselined after a perception change.

The dog's committed suite is copied to a temporary folder with a copy of its
perception module, ``SPEED_SMOOTHING`` retuned (0.05 to 0.1 by default: the speed
then differs in nearly every cycle). Every spec names the copy; the suite runs with
``--update``, and each pending baseline written is weighed against its log: the whole
file as written (a long one zstd-compressed), its text, and its robot-state lines alone
(what pins the rebuilt robot states). DTCs the change cannot re-baseline (their
behaviors then draw other random numbers) write no file and are left out of the sums.

Run it as ``python bench/bench_baselines.py [--smoothing 0.1] [--jobs N] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import inspect
import json
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any, NamedTuple

from beatlog.baseline.file import pending_path, text_blocks
from beatlog.baseline.policy import UpdateMode
from beatlog.suite.discovery import discover_specs
from beatlog.suite.maintenance import UpdateAction, update_baselines
from beatlog.suite.parallel import run_suite
from beatlog_examples.dog import SUITE_DIR, perception

_MODULE = "retuned_perception"


class Weight(NamedTuple):
    """One pending baseline against its log, in bytes."""

    name: str
    log: int
    baseline: int
    """The file as written."""
    text: int
    """Its text (the file's own bytes, unless it is compressed)."""
    robot_states: int
    """The robot-state lines of the baseline."""
    pinned_cycles: int


def retuned_suite(folder: Path, smoothing: float) -> Path:
    """A copy of the dog's suite in ``folder`` whose specs name a perception with
    ``SPEED_SMOOTHING`` set to ``smoothing``; the copy's folder."""
    suite = folder / "suite"
    shutil.copytree(SUITE_DIR, suite, ignore=shutil.ignore_patterns("*.dtc.expected"))
    source, count = re.subn(
        r"^SPEED_SMOOTHING = .*$",
        f"SPEED_SMOOTHING = {smoothing!r}",
        inspect.getsource(perception),
        flags=re.MULTILINE,
    )
    assert count == 1, "the dog's perception no longer sets SPEED_SMOOTHING"
    (suite / f"{_MODULE}.py").write_text(source, encoding="utf-8")
    for spec in suite.glob("*.dtc.toml"):
        text = spec.read_text(encoding="utf-8")
        spec.write_text(
            re.sub(r"^perception = .*$", f'perception = "{_MODULE}:perception"', text, flags=re.M),
            encoding="utf-8",
        )
    return suite


def weigh(suite: Path, jobs: int) -> list[Weight]:
    """Run the suite with ``--update``; each pending baseline written, weighed."""
    specs = discover_specs([suite])
    outcomes = run_suite(specs, jobs=jobs, update=UpdateMode.NEW)
    weights = []
    for update in update_baselines(outcomes, UpdateMode.NEW):
        if update.action is not UpdateAction.WRITTEN or update.baseline is None:
            continue
        pending = pending_path(update.spec.path)
        text = "".join(text_blocks(pending))
        pins = sum(
            len(line.encode())
            for line in text.splitlines(keepends=True)
            if not line.startswith("#") and "  robot_state " in line
        )
        weights.append(
            Weight(
                update.spec.name,
                update.spec.log.stat().st_size,
                pending.stat().st_size,
                len(text.encode()),
                pins,
                update.baseline.approved_states.cycles,
            )
        )
    return weights


def _percent(part: int, whole: int) -> str:
    return f"{100 * part / whole:5.2f} %"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoothing", type=float, default=0.1, help="the retuned constant")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        weights = weigh(retuned_suite(Path(folder), args.smoothing), args.jobs)
    print(
        f"{'DTC':<20} {'log':>9} {'baseline':>9} {'':>7} {'text':>9} {'robot states':>12} {'':>7}"
    )
    for w in weights:
        print(
            f"{w.name:<20} {w.log:>9} {w.baseline:>9} {_percent(w.baseline, w.log)} "
            f"{w.text:>9} {w.robot_states:>12} {_percent(w.robot_states, w.log)}"
        )
    logs = sum(w.log for w in weights)
    baselines = sum(w.baseline for w in weights)
    texts = sum(w.text for w in weights)
    states = sum(w.robot_states for w in weights)
    cycles = sum(w.pinned_cycles for w in weights)
    figures: dict[str, Any] = {
        "smoothing": args.smoothing,
        "dtcs": len(weights),
        "log_bytes": logs,
        "baseline_bytes": baselines,
        "text_bytes": texts,
        "robot_state_bytes": states,
        "pinned_cycles": cycles,
        "per_dtc": [w._asdict() for w in weights],
    }
    print(
        f"{len(weights)} pending baselines: {baselines} bytes, {_percent(baselines, logs)} of "
        f"their logs' {logs} (their text {texts} bytes); robot-state lines {states} bytes, "
        f"{_percent(states, logs)}, "
        f"{states / max(cycles, 1):.2f} bytes a pinned cycle ({cycles} cycles)"
    )
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
