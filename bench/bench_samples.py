"""What replay from samples costs on top of state replay, against perception's own work.

On the dog's committed suite (recorded with its samples), three things are timed in
CPU time (``time.process_time``), alternated round by round in one run:

- state: ``replay(log, system)``, the recorded robot states read from the log;
- sensor: ``replay(log, system, perception=...)``, each robot state rebuilt from the
  samples, compared with the recorded one, and the behaviors run on it;
- perception: the perception step alone, folding the samples (decoded beforehand,
  outside the timing) of every cycle into the state, as replay calls it.

The target: (sensor - state) / perception <= 1, i.e. replay from samples costs at
most perception's own work on top of state replay. The samples' decoding is timed
too (alone, outside the ratio) to say where anything above 1 goes.

Run it as ``python bench/bench_samples.py [--rounds 5] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec

from beatlog.log.reader import SessionLogReader
from beatlog.model.inbox import Sample
from beatlog.project.usercode import load_perception, load_system
from beatlog.replay.judge import replay
from beatlog.suite.discovery import discover_specs
from beatlog.suite.spec import DtcSpec
from beatlog_examples.dog import SUITE_DIR


def samples_of(log: Path) -> list[bytes]:
    """Each cycle's encoded samples, as the log holds them."""
    with SessionLogReader(log) as reader:
        return [bytes(record.samples) for batch in reader.batches() for record in batch]


def timed(work: Callable[[], object]) -> float:
    started = time.process_time()
    work()
    return time.process_time() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    specs = [spec for spec in discover_specs([SUITE_DIR]) if spec.perception]
    assert specs, "the dog's suite names its perception step"
    encoded = {spec.path: samples_of(spec.log) for spec in specs}
    decode = msgspec.msgpack.Decoder(list[Sample]).decode
    decoded = {path: [decode(cycle) for cycle in cycles] for path, cycles in encoded.items()}
    cycles = sum(len(each) for each in encoded.values())

    def state() -> None:
        for spec in specs:
            _check(replay(spec.log, systems.pop(), explain=False), spec)

    def sensor() -> None:
        for spec in specs:
            result = replay(spec.log, systems.pop(), explain=False, perception=perceptions.pop())
            _check(result, spec)

    def perception_alone() -> None:
        for spec in specs:
            perceive, previous = perceptions.pop(), None
            for samples in decoded[spec.path]:
                previous = perceive(previous, samples)

    def decoding_alone() -> None:
        for spec in specs:
            for cycle in encoded[spec.path]:
                decode(cycle)

    kinds: dict[str, Callable[[], None]] = {
        "state": state,
        "sensor": sensor,
        "perception": perception_alone,
        "decoding": decoding_alone,
    }
    times: dict[str, list[float]] = {kind: [] for kind in kinds}
    for _ in range(args.rounds):
        for kind, work in kinds.items():  # alternated: one of each per round
            # Fresh systems and perception steps, built outside the timing.
            systems = [load_system(_system(spec)) for spec in reversed(specs)]
            perceptions = [load_perception(str(spec.perception)) for spec in reversed(specs)]
            times[kind].append(timed(work))
    median = {kind: statistics.median(values) for kind, values in times.items()}
    ratio = (median["sensor"] - median["state"]) / median["perception"]
    figures: dict[str, Any] = {
        "dtcs": len(specs),
        "cycles": cycles,
        "rounds": args.rounds,
        "cpu_s": times,
        "median_cpu_s": median,
        "us_per_cycle": {kind: value / cycles * 1e6 for kind, value in median.items()},
        "ratio": ratio,
        "ratio_per_round": [
            (sensor_s - state_s) / perception_s
            for state_s, sensor_s, perception_s in zip(
                times["state"], times["sensor"], times["perception"], strict=True
            )
        ],
    }
    for kind in kinds:
        print(
            f"{kind:<11} median {median[kind]:7.3f} s CPU  "
            f"({figures['us_per_cycle'][kind]:6.1f} µs/cycle; rounds "
            + ", ".join(f"{value:.3f}" for value in times[kind])
            + ")"
        )
    print(
        f"(sensor - state) / perception = {ratio:.2f} on {len(specs)} DTCs, {cycles:,} cycles "
        f"(target <= 1: {'met' if ratio <= 1 else 'missed'}); per round "
        + ", ".join(f"{value:.2f}" for value in figures["ratio_per_round"])
    )
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")


def _system(spec: DtcSpec) -> str:
    assert spec.system is not None, f"{spec.name} names its system"
    return spec.system


def _check(result: Any, spec: DtcSpec) -> None:
    """Timings of a replay that diverged would be of a shorter replay."""
    assert result.ok, f"{spec.name}: {result.divergence}"


if __name__ == "__main__":
    main()
