"""Re-record the dog's DTC suite: every scenario live, in real time, with one command.

::

    python -m beatlog_examples.dog.record_suite                  # all 22, into suite/
    python -m beatlog_examples.dog.record_suite --only push-over # one test case
    python -m beatlog_examples.dog.record_suite some/folder      # somewhere else

Each test case gets its session log ``NAME.beatlog`` and its spec ``NAME.dtc.toml``
(name, purpose, the scenario's procedure, log, system, tags, the dog's invariants and
what its variants perturb, :mod:`beatlog_examples.dog.variants`); a
log already there is replaced, as re-recording means. Recording takes as long as the
sessions last (about 18 minutes for the whole suite).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from beatlog.suite import spec
from beatlog.suite.spec import SPEC_SUFFIX
from beatlog_examples.dog import SUITE_DIR, invariants
from beatlog_examples.dog.robot import PERCEPTION_REF, SYSTEM_REF, record_live
from beatlog_examples.dog.scenarios import SUITE, Scenario
from beatlog_examples.dog.variants import VARIANTS

__all__ = ["main", "spec_text"]


def spec_text(scenario: Scenario, log: str) -> str:
    """The ``*.dtc.toml`` for a scenario's recording."""
    return spec.spec_text(
        name=scenario.name,
        purpose=scenario.purpose,
        procedure=scenario.procedure(),
        log=log,
        system=SYSTEM_REF,
        tags=scenario.tags,
        perception=PERCEPTION_REF,
        invariants=invariants.ALL,
        variants=VARIANTS,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Record the chosen scenarios; 0 when every recording finished cleanly."""
    parser = argparse.ArgumentParser(
        prog="python -m beatlog_examples.dog.record_suite",
        description="Record the robot dog's DTC suite live, in real time.",
    )
    parser.add_argument("folder", nargs="?", type=Path, default=SUITE_DIR)
    parser.add_argument(
        "--only", action="append", default=[], metavar="NAME", help="record just this case"
    )
    parser.add_argument("--seed", type=int, help="seed of the random source (default: fresh)")
    args = parser.parse_args(argv)
    names = {scenario.name for scenario in SUITE}
    unknown = [name for name in args.only if name not in names]
    if unknown:
        parser.error(f"no scenario named {unknown[0]!r}; choose from {', '.join(sorted(names))}")
    chosen = [s for s in SUITE if not args.only or s.name in args.only]
    folder: Path = args.folder
    folder.mkdir(parents=True, exist_ok=True)
    failed = 0
    for scenario in chosen:
        log = folder / f"{scenario.name}.beatlog"
        print(f"recording {scenario.name} ({scenario.duration_s:g} s) ...", flush=True)
        summary = record_live(log, scenario, overwrite=True, seed=args.seed, log_samples=True)
        (folder / f"{scenario.name}{SPEC_SUFFIX}").write_text(
            spec_text(scenario, log.name), encoding="utf-8"
        )
        print(
            f"  {summary.cycles} cycles, {summary.overruns} overruns"
            + (f", error: {summary.error}" if summary.error else ""),
            flush=True,
        )
        failed += summary.error is not None
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
