"""Format 3's two layouts of one session: replay of robot states stored in the records
and stored by field, against the bare loop, at several widths (``COLUMNS_FROM``).

For each width F the script records the synthetic session of ``bench_width.py`` (B
behaviors reading 3 fields each, F fields) twice, once each way
(``Recorder(by_field=...)``), then replays both and runs the bare loop
(``bench/bare.py``) alternately ``--rounds`` times in one process, timed in CPU time
(``time.process_time``). It reports each log's bytes per cycle, each replay's µs per
cycle and its ratio to the bare loop (ratio of the medians), and the median over the
rounds of by field / in the records.

Run it as ``python bench/bench_layouts.py [--widths 10,80,100,1000] [--behaviors 10]
[--cycles 2000] [--rounds 11]``. Nothing here asserts a timing.
"""

from __future__ import annotations

import argparse
import functools
import statistics
import tempfile
from pathlib import Path

from bare import cpu, load_bare_inputs, replay_fresh, run_bare
from beatlog.record import Recorder
from bench_width import PERIOD_NS, SEED, maker, states, wide_state, wide_system

LAYOUTS = {"records": False, "by field": True}


def record(path: Path, behaviors: int, fields: int, cycles: int, *, by_field: bool) -> float:
    """Record the session into ``path`` stored ``by_field`` or not; its bytes per cycle."""
    system = wide_system(behaviors, fields)
    with Recorder(path, system, seed=SEED, software="bench", by_field=by_field) as recorder:
        for state in states(fields, cycles):
            recorder.step(PERIOD_NS, state)
    return path.stat().st_size / cycles


def compare(directory: Path, behaviors: int, fields: int, cycles: int, rounds: int) -> list[str]:
    """Both layouts of one width replayed against the bare loop, alternately."""
    logs = {name: directory / f"{name.replace(' ', '-')}-{fields}.beatlog" for name in LAYOUTS}
    sizes = {
        name: record(logs[name], behaviors, fields, cycles, by_field=by_field)
        for name, by_field in LAYOUTS.items()
    }
    make = maker(behaviors, fields)
    inputs = load_bare_inputs(logs["records"], wide_state(fields))
    spent: dict[str, list[float]] = {name: [] for name in (*LAYOUTS, "bare")}
    for _ in range(rounds):
        for name, log in logs.items():
            seconds, (result, _) = cpu(functools.partial(replay_fresh, log, make))
            assert result.ok, result.divergence
            spent[name].append(seconds)
        spent["bare"].append(cpu(lambda: run_bare(inputs, make))[0])
    bare = statistics.median(spent["bare"])
    against = statistics.median(
        by_field / in_records
        for by_field, in_records in zip(spent["by field"], spent["records"], strict=True)
    )
    lines = [f"B={behaviors}, F={fields}: bare {bare / cycles * 1e6:.1f} µs/cycle"]
    for name in LAYOUTS:
        median = statistics.median(spent[name])
        lines.append(
            f"  {name}: {sizes[name]:.1f} bytes/cycle, replay {median / cycles * 1e6:.1f} "
            f"µs/cycle, replay / bare {median / bare:.2f}"
        )
    lines.append(f"  by field / records, median of the rounds: {against:.3f}")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--widths", default="10,50,64,80,100,1000")
    parser.add_argument("--behaviors", type=int, default=10)
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=11)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        for fields in map(int, args.widths.split(",")):
            lines = compare(Path(directory), args.behaviors, fields, args.cycles, args.rounds)
            print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
