"""What a variant costs against one replay of its DTC: the target is at most 1.1 x.

On the dog's committed suite (sensor-level, its samples logged), each DTC is replayed
as ``beatlog test`` judges it (``replay(log, system, perception=..., invariants=...)``
with the spec's invariants) and as variant 1 of it (``replay_variant``, the same
invariants) with the perturbations named: by default every one, fresh draws, heartbeat
jitter, noise on two robot-state fields, and samples dropped and delayed;
``--perturb draws,jitter,noise,samples`` names fewer. ``--no-invariants`` leaves the
invariants out of both.
CPU time (``time.process_time``), the two alternated round by round in one run; the
ratio is the sums' over the suite, medians of the rounds, and a DTC's own where asked.
A variant that fails stops early: the cycles each replayed are reported beside.

Run it as ``python bench/bench_variants.py [--rounds 5] [--dtc NAME] [--perturb ...]
[--no-invariants] [--json FILE]``. For
instruction counts, ``--run replay|variant --times N`` replays the suite once each way
as a warm-up and N more times the way named: under ``PYTHONHASHSEED=0 valgrind
--tool=cachegrind --cache-sim=no``, the difference of the ``I refs`` counts of N = 1
and N = 0 is one pass, the set-up left out. ``--blind`` (with ``--run variant``) hands
the behaviors one robot state whatever the variant makes of it, and checks no invariant
(a blind dog breaks them): what a variant costs beyond ``--perturb none`` is then the
perturbations' own work, the behaviors' reaction to a perturbed world left out.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from beatlog.model.behavior import PriorityArbiter, System
from beatlog.model.context import Context
from beatlog.project.usercode import load_perception, load_system
from beatlog.replay.judge import replay
from beatlog.replay.perturbation import Perturbations, Variant
from beatlog.replay.variant import replay_variant
from beatlog.suite.discovery import discover_specs
from beatlog.suite.spec import DtcSpec
from beatlog_examples.dog import SUITE_DIR

PERTURBED = Perturbations(
    heartbeat_jitter=0.002,
    noise={"battery": 0.05, "nearest": 0.01},
    drop_samples=0.05,
    delay_samples=0.05,
)
"""Every perturbation a variant makes."""


def perturbations(names: str) -> Perturbations:
    """Those of :data:`PERTURBED` named (``draws,jitter,noise,samples``)."""
    named = set(names.split(","))
    return Perturbations(
        draws="draws" in named,
        heartbeat_jitter=PERTURBED.heartbeat_jitter if "jitter" in named else 0.0,
        noise=PERTURBED.noise if "noise" in named else {},
        drop_samples=PERTURBED.drop_samples if "samples" in named else 0.0,
        delay_samples=PERTURBED.delay_samples if "samples" in named else 0.0,
    )


class Blind(PriorityArbiter[Any]):
    """A system's behaviors, each cycle given one robot state, its type's default."""

    _held: Any = None

    def update(self, state: Any, context: Context) -> None:
        super().update(self._held, context)

    @classmethod
    def of(cls, system: System) -> Blind:
        assert isinstance(system, PriorityArbiter)
        children: list[Any] = [b for b in system.behaviors.values() if b is not system]
        blind = cls(
            children,
            robot_state=system.robot_state,
            name=system.name,
            per_output=system.per_output,
        )
        blind._held = system.robot_state()
        return blind


def as_judged(spec: DtcSpec, invariants: bool) -> int:
    """Replay the DTC as ``beatlog test`` judges it; its cycles."""
    assert spec.system is not None
    assert spec.perception is not None
    result = replay(
        spec.log,
        load_system(spec.system),
        perception=load_perception(spec.perception),
        explain=False,
        invariants=spec.invariants if invariants else (),
    )
    assert result.ok, (spec.name, result.divergence)
    return result.cycles


def as_variant(
    spec: DtcSpec, invariants: bool, perturbed: Perturbations = PERTURBED, blind: bool = False
) -> int:
    """Replay variant 1 of the DTC (its behaviors ``blind``: see :class:`Blind`); its cycles."""
    assert spec.system is not None
    assert spec.perception is not None
    system = load_system(spec.system)
    result = replay_variant(
        spec.log,
        Blind.of(system) if blind else system,
        Variant(1, perturbed),
        perception=load_perception(spec.perception),
        invariants=spec.invariants if invariants and not blind else (),
    )
    return result.cycles


def timed(work: Callable[[], object]) -> float:
    started = time.process_time()
    work()
    return time.process_time() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--run", choices=("replay", "variant"))
    parser.add_argument("--times", type=int, default=1)
    parser.add_argument("--dtc", action="append", help="only this DTC (again for more)")
    parser.add_argument("--perturb", default="draws,jitter,noise,samples")
    parser.add_argument("--no-invariants", dest="invariants", action="store_false")
    parser.add_argument("--blind", action="store_true", help="with --run variant: see Blind")
    args = parser.parse_args()
    perturbed = perturbations(args.perturb)
    checks = args.invariants

    def judged_run(spec: DtcSpec) -> int:
        return as_judged(spec, checks)

    def variant_run(spec: DtcSpec) -> int:
        return as_variant(spec, checks, perturbed, args.blind)

    specs = [
        spec for spec in discover_specs([SUITE_DIR]) if args.dtc is None or spec.name in args.dtc
    ]
    if args.run is not None:
        for spec in specs:
            judged_run(spec)
            variant_run(spec)
        for _ in range(args.times):
            for spec in specs:
                (judged_run if args.run == "replay" else variant_run)(spec)
        return
    cycles = {spec.name: (judged_run(spec), variant_run(spec)) for spec in specs}  # warm-up
    judged: dict[str, list[float]] = {spec.name: [] for spec in specs}
    varied: dict[str, list[float]] = {spec.name: [] for spec in specs}
    for _ in range(args.rounds):
        for spec in specs:
            judged[spec.name].append(timed(lambda spec=spec: judged_run(spec)))  # type: ignore[misc]
            varied[spec.name].append(timed(lambda spec=spec: variant_run(spec)))  # type: ignore[misc]
    rounds = range(args.rounds)
    judged_total = statistics.median(sum(judged[n][r] for n in judged) for r in rounds)
    varied_total = statistics.median(sum(varied[n][r] for n in varied) for r in rounds)
    rows = {
        name: {
            "cycles": cycles[name][0],
            "variant_cycles": cycles[name][1],
            "replay_s": statistics.median(judged[name]),
            "variant_s": statistics.median(varied[name]),
            "ratio": statistics.median(varied[name]) / statistics.median(judged[name]),
        }
        for name in judged
    }
    for name, row in rows.items():
        print(
            f"{name:24} {row['cycles']:6} {row['variant_cycles']:6} cycles  "
            f"replay {row['replay_s']:.3f} s  variant {row['variant_s']:.3f} s  "
            f"x {row['ratio']:.3f}"
        )
    ratio = varied_total / judged_total
    print(f"suite: replay {judged_total:.3f} s, variant {varied_total:.3f} s: x {ratio:.3f}")
    if args.json is not None:
        args.json.write_text(
            json.dumps({"rows": rows, "replay_s": judged_total, "variant_s": varied_total}),
            encoding="utf-8",
        )


if __name__ == "__main__":
    main()
