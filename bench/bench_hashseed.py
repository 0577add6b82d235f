"""Verdicts do not depend on the hash seed: the dog's suite rerun with varied ``PYTHONHASHSEED``.

Each run is a fresh ``beatlog test`` process (its worker processes inherit the seed)
on a copy of the suite, writing a JUnit report and the transition coverage as JSON.
Every run's exit code, verdicts (from the JUnit report), JUnit report (times, host
name and timestamp left out) and coverage JSON are compared with the first run's; the
bench prints 0 changes or lists each one.

Run it as ``python bench/bench_hashseed.py [--runs 100] [--suite DIR] [--jobs N]
[--json FILE]``; on 2 cores a run of the dog suite takes about 7 s.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, NamedTuple

from beatlog_examples.dog import SUITE_DIR

_VOLATILE = {"time", "timestamp", "hostname"}
"""JUnit attributes that differ from run to run whatever the verdicts."""


class Run(NamedTuple):
    """What one ``beatlog test`` run gave."""

    seed: int
    code: int
    verdicts: dict[str, str]
    junit: str
    coverage: str


def seeds(runs: int) -> list[int]:
    """``runs`` distinct hash seeds spread over the whole range (0 turns hashing
    randomisation off, so it is not among them)."""
    return [1 + (index * 2_654_435_761) % (2**32 - 1) for index in range(runs)]


def normal_junit(path: Path) -> tuple[str, dict[str, str]]:
    """The JUnit report without its volatile attributes, and each test case's verdict."""
    root = ET.parse(path).getroot()
    verdicts: dict[str, str] = {}
    for element in root.iter():
        for name in _VOLATILE & element.attrib.keys():
            del element.attrib[name]
        if element.tag == "testcase":
            outcome = next(
                (child.tag for child in element if child.tag in ("failure", "error", "skipped")),
                "passed",
            )
            verdicts[element.attrib["name"]] = outcome
    return ET.tostring(root, encoding="unicode"), verdicts


def run_once(suite: Path, out: Path, seed: int, jobs: int) -> Run:
    junit, coverage = out / f"junit-{seed}.xml", out / f"coverage-{seed}.json"
    command = [sys.executable, "-m", "beatlog.cli.main", "test", str(suite), "-j", str(jobs)]
    command += ["--junit-xml", str(junit), "--coverage-json", str(coverage)]
    env = {**os.environ, "PYTHONHASHSEED": str(seed)}
    env.pop("CI", None)
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    if not junit.exists():
        return Run(seed, done.returncode, {}, done.stderr, "")
    text, verdicts = normal_junit(junit)
    return Run(seed, done.returncode, verdicts, text, coverage.read_text(encoding="utf-8"))


def changes(first: Run, run: Run) -> list[str]:
    """What differs between two runs, one line each."""
    found = []
    if run.code != first.code:
        found.append(f"exit code {first.code} -> {run.code}")
    for name in sorted(first.verdicts.keys() | run.verdicts.keys()):
        was, now = first.verdicts.get(name), run.verdicts.get(name)
        if was != now:
            found.append(f"{name}: {was} -> {now}")
    if run.junit != first.junit:
        found.append("the JUnit report differs")
    if run.coverage != first.coverage:
        found.append("the coverage JSON differs")
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--suite", type=Path, default=SUITE_DIR)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    started = time.perf_counter()
    differences: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        suite = Path(tmp) / "suite"  # the coverage memory goes beside the copy
        shutil.copytree(args.suite, suite, ignore=shutil.ignore_patterns(".*"))
        out = Path(tmp) / "out"
        out.mkdir()
        runs: list[Run] = []
        for number, seed in enumerate(seeds(args.runs), start=1):
            runs.append(run_once(suite, out, seed, args.jobs))
            found = changes(runs[0], runs[-1])
            if found:
                differences.append({"seed": seed, "changes": found})
            print(
                f"run {number:>3}/{args.runs}  PYTHONHASHSEED={seed:<10}  exit {runs[-1].code}  "
                f"{sum(v == 'passed' for v in runs[-1].verdicts.values())}"
                f"/{len(runs[-1].verdicts)} passed  {'; '.join(found) or 'same'}",
                flush=True,
            )
    figures = {
        "runs": len(runs),
        "dtcs": len(runs[0].verdicts),
        "first_exit_code": runs[0].code,
        "first_verdicts": runs[0].verdicts,
        "runs_with_changes": len(differences),
        "differences": differences,
        "wall_s": time.perf_counter() - started,
    }
    print(
        f"{len(differences)} of {len(runs)} runs differ from the first "
        f"({len(runs[0].verdicts)} DTCs, exit code {runs[0].code}) in "
        f"{figures['wall_s']:.0f} s"
    )
    for difference in differences:
        print(f"  PYTHONHASHSEED={difference['seed']}: {'; '.join(difference['changes'])}")
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
