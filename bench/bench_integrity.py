"""What the log's integrity checks cost, and how fast hostile inputs are refused.

1. Replay of the 35,000-cycle rover log with the reader's integrity checks against the
   same replay with a reader whose checks are switched off (order, end counts,
   summary, channels), CPU time, alternated in one run.
2. ``beatlog show`` on hostile files of at most 1 MB, each in a fresh interpreter:
   CPU time and peak memory (goal: within 5 s and 150 MB each), and the exit code.

Run it as ``python bench/bench_integrity.py [--rounds N]``; it takes about a minute.
Nothing here asserts a timing.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import msgspec
import zstandard
from mcap import records

from beatlog.log.format import CYCLES_TOPIC, CycleRecord, SessionEnd
from beatlog.log.payload import decode_payload
from beatlog.log.reader import SessionLogReader
from beatlog_examples.rover import record_lockstep, system

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' crafted logs
from tests import crafting

replay_module: Any = importlib.import_module("beatlog.replay.judge")
"""The module (``beatlog.replay.judge`` the attribute is the function of that name)."""

DURATION_S = 1050.0
"""The paper's 17.5 minutes: 35,000 cycles at 30 ms."""


class UncheckedReader(SessionLogReader):
    """The reader with the integrity checks of format 2 switched off: batches are only
    decoded, the end record and the summary are not compared, channels not vetted."""

    def __init__(self, path: Any, **options: Any) -> None:
        super().__init__(path, **options)
        self._stream.check_summary = lambda *_: None  # type: ignore[method-assign]

    def _batch(self, message: records.Message, *, skim: bool = False) -> list[CycleRecord]:
        decoded = (self._decoding.skim if skim else self._decoding.decode)(message.data)
        batch: list[CycleRecord] = decoded.cycles if hasattr(decoded, "cycles") else decoded
        self._cycles += len(batch)
        return batch

    def _read_end(self, message: records.Message) -> None:
        self.end = decode_payload(self.path, message.data, SessionEnd, "end record")


def cpu_of(run: Callable[[], Any]) -> float:
    started = time.process_time()
    run()
    return time.process_time() - started


@contextlib.contextmanager
def reader_class(reader: type[SessionLogReader]) -> Iterator[None]:
    original = replay_module.SessionLogReader
    replay_module.SessionLogReader = reader
    try:
        yield
    finally:
        replay_module.SessionLogReader = original


def bench_checks(log: Path, rounds: int) -> dict[str, float]:
    def checked() -> None:
        assert replay_module.replay(log, system()).ok

    def unchecked() -> None:
        with reader_class(UncheckedReader):
            assert replay_module.replay(log, system()).ok

    ratios, with_checks, without = [], [], []
    for _ in range(rounds):
        a = cpu_of(checked)
        b = cpu_of(unchecked)
        with_checks.append(a)
        without.append(b)
        ratios.append(a / b)
    return {
        "with_checks_s": statistics.median(with_checks),
        "without_checks_s": statistics.median(without),
        "ratio_median": statistics.median(ratios),
        "ratio_min": min(ratios),
        "ratio_max": max(ratios),
    }


def hostile_files(folder: Path, real: Path) -> dict[str, Path]:
    files = {
        "50 MB robot id": crafting.craft_log(
            folder / "robot-id.beatlog",
            [crafting.header_message(robot_id="r" * 50_000_000), *crafting.cycle_messages(5)],
        ),
        "200,000 behaviors": crafting.craft_log(
            folder / "behaviors.beatlog",
            [
                crafting.header_message(behaviors=[f"b{i}" for i in range(200_000)]),
                *crafting.cycle_messages(5),
            ],
        ),
        "msgpack 100,000 deep": crafting.craft_log(
            folder / "deep.beatlog",
            [crafting.header_message(robot_state_schema=crafting.deeply_nested())],
        ),
    }
    bomb_log = crafting.craft_log(folder / "bomb.beatlog", crafting.standard_messages(30))
    data = bomb_log.read_bytes()
    bomb = zstandard.compress(b"\0" * (1 << 30))
    for name, declared in (
        ("zstd bomb claiming 1 GiB", 1 << 30),
        ("zstd bomb claiming 1 KiB", 1 << 10),
    ):
        path = folder / f"bomb-{declared}.beatlog"
        path.write_bytes(
            crafting.replace_chunk_content(data, crafting.chunks(data)[1], bomb, declared=declared)
        )
        files[name] = path
    real_data = real.read_bytes()[: 1 << 20]
    files["real log cut at 1 MB"] = folder / "cut.beatlog"
    files["real log cut at 1 MB"].write_bytes(real_data)
    flipped = bytearray(real_data)
    for position in range(1000, len(flipped), len(flipped) // 20):
        flipped[position] ^= 0x55
    files["real log, 20 bytes flipped"] = folder / "flipped.beatlog"
    files["real log, 20 bytes flipped"].write_bytes(bytes(flipped))
    files["9M identical minimal cycles"] = crafting.craft_log(
        folder / "minimal.beatlog", minimal_cycles(9_000_000), chunk_size=1 << 20
    )
    whole = crafting.craft_log(folder / "whole.beatlog", crafting.standard_messages(2000))
    whole_data = whole.read_bytes()
    files["chunk dropped"] = folder / "dropped.beatlog"
    files["chunk dropped"].write_bytes(
        crafting.drop_chunk(whole_data, crafting.chunks(whole_data)[50])
    )
    return files


MEASURE = """
import resource, subprocess, sys
done = subprocess.run([sys.executable, "-m", "beatlog.cli.main", "show", sys.argv[1]],
                      capture_output=True, text=True, timeout=120, check=False)
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
said = (done.stderr or done.stdout).strip().splitlines()[-1]
print(done.returncode, usage.ru_utime + usage.ru_stime, usage.ru_maxrss, said)
"""
"""Runs ``beatlog show`` as its only child, so the child's CPU time and peak RSS are its own."""


def minimal_cycles(count: int) -> list[crafting.Message]:
    """A valid log's messages whose cycles are all the smallest possible: the most work
    a file of a given size can ask for (it compresses about 100 times)."""
    smallest = msgspec.Raw(msgspec.msgpack.encode([crafting.PERIOD_NS, {}, [], [], {}, []]))
    messages = [crafting.header_message()]
    for first in range(0, count, 256):
        size = min(256, count - first)
        payload = msgspec.msgpack.encode([first, [smallest] * size])
        messages.append(crafting.Message(CYCLES_TOPIC, (first + 1) * crafting.PERIOD_NS, payload))
    return [*messages, crafting.end_message(count)]


def show_in_child(path: Path) -> dict[str, Any]:
    done = subprocess.run(
        [sys.executable, "-c", MEASURE, str(path)],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    code, cpu, peak_kb, said = done.stdout.split(" ", 3)
    return {
        "bytes": path.stat().st_size,
        "exit": int(code),
        "cpu_s": float(cpu),
        "peak_mb": int(peak_kb) / 1024,
        "said": said.strip()[-90:],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="alternated replays of each kind")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        log = Path(folder) / "rover.beatlog"
        summary = record_lockstep(log, duration_s=DURATION_S, seed=1)
        print(f"log: {summary.cycles} cycles, {log.stat().st_size / 1e6:.2f} MB")
        figures = bench_checks(log, args.rounds)
        print(
            f"replay CPU, median of {args.rounds}: with checks {figures['with_checks_s']:.3f} s, "
            f"without {figures['without_checks_s']:.3f} s; ratio median "
            f"{figures['ratio_median']:.3f} (range {figures['ratio_min']:.3f}-"
            f"{figures['ratio_max']:.3f})"
        )
        print("\nbeatlog show on hostile inputs, each in a fresh interpreter")
        for name, path in hostile_files(Path(folder), log).items():
            row = show_in_child(path)
            print(
                f"  {name:28} {row['bytes']:>9,} B  exit {row['exit']}  cpu {row['cpu_s']:.2f} s  "
                f"peak {row['peak_mb']:.0f} MB  {row['said']}"
            )


if __name__ == "__main__":
    main()
