"""Wide robot states and many behaviors (issue 22): what replay and recording cost as the
robot state grows to F fields and the catalogue to B behaviors.

A synthetic system built on beatlog's public API only (``beatlog.model``, ``Recorder``,
``beatlog.replay``): B behaviors under a :class:`~beatlog.model.PriorityArbiter`, a
quarter each of four kinds (hysteresis, timed wander with a random draw per turn, escape,
a boredom level), each reading 3 fields of a robot state of F fields (80 % float, 10 %
int, 10 % bool), every field a noisy sinusoid, so that every field changes every beat.
For each (B, F) of the grid the script records ``--cycles`` beats in lockstep (30 ms a
beat, the recorder's default 1 s flush interval) into a temporary directory, then
reports:

- instructions per cycle of one replay and of one bare loop (``bench/bare.py``: the same
  behaviors on robot states and draws decoded beforehand), counted by valgrind's
  cachegrind (``I refs``) under ``setarch -R`` with ``PYTHONHASHSEED=0`` and one BLAS
  thread (``OPENBLAS_NUM_THREADS=1``, :data:`QUIET_THREADS`): each is the
  difference between a process that runs it twice and one that runs it once (the first
  run warms up), over the cycles; and their ratio;
- CPU time of replay / bare loop (``time.process_time``), alternated ``--rounds`` times
  in one run, the ratio of the medians (with the checked loop, ``bare.run_checked``);
- the log's bytes per cycle;
- the control thread's CPU time per beat in ``Recorder.step`` (``time.thread_time``, so
  the writer thread's work is not counted), against stepping the system alone
  (``CycleExecutor.step`` and ``RecordingRandom.take``: what ``Recorder.step`` does
  besides recording); and what building one robot state costs, by keywords, positionally
  and with :func:`msgspec.convert` from a dict.

``--split`` adds, per width, where reading the log goes (the other half of issue 22's
question): CPU time of reading the batches with the robot states skipped, decoded whole,
and decoded into a narrow struct of only the fields the behaviors read (unknown fields
skipped), and zstd decompression and CRC of the chunks alone.

Run it as ``python bench/bench_width.py [--grid 10x10,10x1000] [--cycles 2000]
[--rounds 5] [--no-instructions] [--split] [--json FILE]``. The full grid (all of
{10, 100, 1000}², with instructions) takes hours on 2 cores; ``--grid`` picks cells.
Nothing here asserts a timing.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator, Sequence
from operator import attrgetter
from pathlib import Path
from typing import Any, NamedTuple, cast

import msgspec
import numpy as np

from bare import cpu, load_bare_inputs, replay_against_bare, replay_fresh, run_bare
from beatlog.log.reader import SessionLogReader
from beatlog.model import (
    BehaviorState,
    Context,
    LiveHeartbeat,
    Outputs,
    PriorityArbiter,
    RecordingRandom,
    RobotState,
    System,
)
from beatlog.model.cycle import CycleExecutor
from beatlog.record import Recorder

GRID = (10, 100, 1000)
PERIOD_NS = 30_000_000
READS = 3
"""Fields each behavior reads."""
SEED = 1

Figures = dict[str, Any]


# -- the robot state ------------------------------------------------------------------


def field_kind(index: int) -> type:
    """80 % float, 10 % int, 10 % bool, interleaved."""
    return bool if index % 10 == 9 else int if index % 10 == 8 else float


def field_name(index: int) -> str:
    return f"{field_kind(index).__name__}_{index:04d}"


@functools.cache
def wide_state(fields: int) -> type[RobotState]:
    """The robot state of ``fields`` fields (one type per width in a process)."""
    spec = [(field_name(i), field_kind(i), field_kind(i)()) for i in range(fields)]
    state = msgspec.defstruct(f"Wide{fields}", spec, bases=(RobotState,), module="bench_width")
    return cast(type[RobotState], state)


def sensed(fields: int, cycles: int, seed: int = SEED) -> Iterator[list[Any]]:
    """Every field of every beat, in field order, as plain Python values: noisy sinusoids
    (periods 2-20 s), ints as tenths rounded, bools as the sign."""
    rng = np.random.default_rng(seed)
    index = np.arange(fields)
    omega = 2 * math.pi / (2.0 + (index * 7) % 19)
    kinds = [field_kind(i) for i in range(fields)]
    floats = [i for i, kind in enumerate(kinds) if kind is float]
    ints = [i for i, kind in enumerate(kinds) if kind is int]
    bools = [i for i, kind in enumerate(kinds) if kind is bool]
    row = np.empty(fields, dtype=object)
    for cycle in range(cycles):
        t = (cycle + 1) * PERIOD_NS / 1e9
        value = np.sin(omega * t + index) + 0.05 * rng.standard_normal(fields)
        row[floats] = value[floats].tolist()
        row[ints] = np.rint(10 * value[ints]).astype(int).tolist()
        row[bools] = (value[bools] > 0).tolist()
        yield row.tolist()


def states(fields: int, cycles: int) -> Iterator[RobotState]:
    """The robot states of a session, built positionally (linear in the width)."""
    state = wide_state(fields)
    for values in sensed(fields, cycles):
        yield state(*values)


# -- the behaviors ----------------------------------------------------------------------


class Reading:
    """A behavior of the synthetic system: it reads 3 fields of the robot state."""

    initial: BehaviorState = None

    def __init__(self, name: str, reads: tuple[str, str, str]) -> None:
        self.name = name
        self.state: BehaviorState = self.initial
        self._read = attrgetter(*reads)
        self._until = 0
        self._level = 0.0


class Hysteresis(Reading):
    """On above +0.6 and off below -0.6 of a mix of two floats; drives while on and a
    flag is set."""

    initial = "off"

    def step(self, state: Any, context: Context) -> Outputs | None:
        a, b, flag = self._read(state)
        level = a + 0.5 * b
        if self.state == "off":
            if level > 0.6:
                self.state = "on"
        elif level < -0.6:
            self.state = "off"
        return {"speed": 0.3 * a} if self.state == "on" and flag else None


class Wander(Reading):
    """Rests and wanders by turns, each turn lasting a random 2-8 s (one draw a turn)."""

    initial = "rest"

    def step(self, state: Any, context: Context) -> Outputs | None:
        a, b, n = self._read(state)
        if context.time_ns >= self._until:
            self.state = "wander" if self.state == "rest" else "rest"
            self._until = context.time_ns + int(context.random.uniform(2.0, 8.0) * 1e9)
        if self.state == "wander":
            return {"turn": 0.1 * a + 0.01 * n, "speed": 0.2 + 0.1 * b}
        return None


class Escape(Reading):
    """Backs off for a second after a bump while a float reads low."""

    initial = "clear"

    def step(self, state: Any, context: Context) -> Outputs | None:
        bump, a, b = self._read(state)
        if self.state == "clear":
            if bump and a < -0.9:
                self.state = "escape"
                self._until = context.time_ns + 1_000_000_000
        elif context.time_ns >= self._until:
            self.state = "clear"
        return {"speed": -0.2, "turn": b} if self.state == "escape" else None


class Boredom(Reading):
    """A boredom level that grows while two floats stay calm and falls otherwise; its
    state is the level in steps of 5, reset when an int reads very high."""

    initial = 0

    def step(self, state: Any, context: Context) -> Outputs | None:
        a, b, n = self._read(state)
        calm = abs(a) < 0.7 and abs(b) < 0.9
        level = self._level + (context.dt if calm else -0.5 * context.dt)
        self._level = level = 0.0 if n >= 11 else min(100.0, max(0.0, level))
        self.state = int(level // 5)
        return None


KINDS = (Hysteresis, Wander, Escape, Boredom)


def reads_of(behavior: int, kind: type, fields: int) -> tuple[str, str, str]:
    """The 3 fields a behavior reads: two floats and, by its kind, a bool or an int (the
    bool first for escape), spread over the state."""
    floats = [i for i in range(fields) if field_kind(i) is float]
    wanted = bool if kind in (Hysteresis, Escape) else int
    others = [i for i in range(fields) if field_kind(i) is wanted]
    a = field_name(floats[(2 * behavior * 37) % len(floats)])
    b = field_name(floats[(2 * behavior * 37 + 1) % len(floats)])
    c = field_name(others[(behavior * 13) % len(others)])
    return (c, a, b) if kind is Escape else (a, b, c)


def wide_system(behaviors: int, fields: int) -> System:
    """B behaviors of the four kinds in turn, under a priority arbiter."""
    members = []
    for number in range(behaviors):
        kind = KINDS[number % len(KINDS)]
        members.append(
            kind(f"{kind.__name__.lower()}_{number:04d}", reads_of(number, kind, fields))
        )
    return PriorityArbiter(members, robot_state=wide_state(fields))


def fields_read(behaviors: int, fields: int) -> list[str]:
    """Every field some behavior reads, in field order."""
    read = {
        name
        for number in range(behaviors)
        for name in reads_of(number, KINDS[number % len(KINDS)], fields)
    }
    return [field_name(i) for i in range(fields) if field_name(i) in read]


def maker(behaviors: int, fields: int) -> Callable[[], System]:
    return functools.partial(wide_system, behaviors, fields)


def system_10x1000() -> System:
    """The 10 x 1,000 cell's system, for ``replay_instructions.py LOG
    bench_width:system_10x1000`` on a log :func:`record` made of that cell."""
    return wide_system(10, 1000)


# -- recording ----------------------------------------------------------------------------


def record(path: Path, behaviors: int, fields: int, cycles: int) -> Figures:
    """Record the session into ``path``: the control thread's CPU per beat in
    ``Recorder.step`` and, in a second pass, in stepping the system alone."""
    step_ns: list[int] = []
    started = time.process_time()
    with Recorder(
        path,
        wide_system(behaviors, fields),
        robot_id=f"wide-{behaviors}x{fields}",
        seed=SEED,
        software="bench",
        start_time_ns=0,
    ) as recorder:
        for state in states(fields, cycles):
            before = time.thread_time_ns()
            recorder.step(PERIOD_NS, state)
            step_ns.append(time.thread_time_ns() - before)
    process_s = time.process_time() - started
    executor = CycleExecutor(wide_system(behaviors, fields), random := RecordingRandom(SEED))
    alone_ns: list[int] = []
    changes = 0
    for state in states(fields, cycles):
        before = time.thread_time_ns()
        changes += len(executor.step(PERIOD_NS, state))
        random.take()
        alone_ns.append(time.thread_time_ns() - before)
    return {
        "recorder_step_us": _spread(step_ns),
        "executor_step_us": _spread(alone_ns),
        "record_process_cpu_s": process_s,
        "state_changes_per_cycle": changes / cycles,
        "bytes_per_cycle": path.stat().st_size / cycles,
    }


def paced(directory: Path, behaviors: int, fields: int, beats: int) -> Figures:
    """``Recorder.step`` as a live robot's control thread sees it: ``beats`` beats on a
    30 ms :class:`~beatlog.model.LiveHeartbeat`, each step timed in wall time and in the
    thread's CPU time; then the same beats stepping the system alone. The wall time
    counts waiting for the writer thread to let go of the GIL."""
    prepared = list(states(fields, beats))
    with Recorder(
        directory / f"paced-{behaviors}x{fields}.beatlog",
        wide_system(behaviors, fields),
        seed=SEED,
        software="bench",
    ) as recorder:
        recording = _paced_steps(recorder.step, prepared)
    random = RecordingRandom(SEED)
    executor = CycleExecutor(wide_system(behaviors, fields), random)

    def step_alone(interval: int, state: Any) -> None:
        executor.step(interval, state)
        random.take()

    return {"recorder": recording, "executor": _paced_steps(step_alone, prepared)}


def _paced_steps(step: Callable[[int, Any], object], prepared: Sequence[Any]) -> Figures:
    wall_ns: list[int] = []
    cpu_ns: list[int] = []
    clock = LiveHeartbeat(PERIOD_NS)
    clock.start()
    for state in prepared:
        interval = clock.wait()
        wall, cpu_before = time.perf_counter_ns(), time.thread_time_ns()
        step(interval, state)
        cpu_ns.append(time.thread_time_ns() - cpu_before)
        wall_ns.append(time.perf_counter_ns() - wall)
    return {"wall_us": _spread(wall_ns), "cpu_us": _spread(cpu_ns), "overruns": clock.overruns}


def _spread(samples_ns: Sequence[int]) -> dict[str, float]:
    ordered = sorted(samples_ns)
    return {
        "p50": ordered[len(ordered) // 2] / 1e3,
        "p99": ordered[min(len(ordered) - 1, int(len(ordered) * 0.99))] / 1e3,
        "max": ordered[-1] / 1e3,
        "mean": statistics.fmean(ordered) / 1e3,
    }


def build_costs(fields: int, rounds: int = 200) -> Figures:
    """CPU µs to build one robot state of ``fields`` fields: by keywords (``State(**kw)``,
    also as a call written out with literal keywords), positionally, with
    ``msgspec.convert`` from a dict, and by ``msgspec.structs.replace`` of all fields."""
    state = wide_state(fields)
    values = next(sensed(fields, 1))
    names = [field_name(i) for i in range(fields)]
    keywords = dict(zip(names, values, strict=True))
    written = (
        "def build(v):\n    return State("
        + ", ".join(f"{name}=v[{i}]" for i, name in enumerate(names))
        + ")\n"
    )
    namespace: dict[str, Any] = {"State": state}
    exec(written, namespace)
    literal = namespace["build"]
    previous = state(*values)
    ways: dict[str, Callable[[], Any]] = {
        "keywords": lambda: state(**keywords),
        "literal_keywords": lambda: literal(values),
        "positional": lambda: state(*values),
        "convert_dict": lambda: msgspec.convert(keywords, state),
        "replace_all": lambda: msgspec.structs.replace(previous, **keywords),
    }
    reference = msgspec.msgpack.encode(previous)
    costs: Figures = {}
    for name, build in ways.items():
        assert msgspec.msgpack.encode(build()) == reference, name
        repeats = max(3, rounds * 10 // fields)
        started = time.process_time()
        for _ in range(repeats):
            build()
        costs[name] = (time.process_time() - started) / repeats * 1e6
    return costs


# -- instructions (cachegrind) ----------------------------------------------------------


def _read_log(path: Path, state_type: type[Any] | None) -> int:
    """Read every batch of ``path``, its robot states decoded into ``state_type`` (left
    as bytes when None); the cycles read."""
    cycles = 0
    with SessionLogReader(path) as reader:
        if state_type is not None:
            reader.decode_states(state_type)
        for batch in reader.batches():
            cycles += len(batch)
    return cycles


def narrow_state(behaviors: int, fields: int) -> type[msgspec.Struct]:
    """A struct of only the fields the behaviors read: decoding into it skips the others."""
    spec = [
        (name, field_kind(int(name[-4:])), field_kind(int(name[-4:]))())
        for name in fields_read(behaviors, fields)
    ]
    narrow: type[msgspec.Struct] = msgspec.defstruct(f"Narrow{fields}", spec)
    return narrow


def counted_runs(log: Path, behaviors: int, fields: int) -> dict[str, Callable[[], object]]:
    """What ``--count`` can run: replay, the bare loop and the reading variants."""
    make = maker(behaviors, fields)
    inputs = load_bare_inputs(log, wide_state(fields))
    narrow = narrow_state(behaviors, fields)

    def replay() -> None:
        result, _ = replay_fresh(log, make)
        assert result.ok, result.divergence

    return {
        "replay": replay,
        "bare": lambda: run_bare(inputs, make),
        "read": lambda: _read_log(log, None),
        "read-decode": lambda: _read_log(log, wide_state(fields)),
        "read-narrow": lambda: _read_log(log, narrow),
    }


COUNTED = ("replay", "bare", "read", "read-decode", "read-narrow")


def count_child(log: Path, behaviors: int, fields: int, kind: str, times: int) -> None:
    """The process valgrind counts: ``kind`` once to warm up, then ``times`` more."""
    run = counted_runs(log, behaviors, fields)[kind]
    for _ in range(1 + times):
        run()


QUIET_THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
"""numpy's BLAS threads spin while they wait, a few million instructions more or less
from run to run; one thread keeps the counts the same from run to run."""
_IREFS = re.compile(r"I\s+refs:\s+([\d,]+)")


def instructions(log: Path, behaviors: int, fields: int, kind: str, cycles: int) -> float:
    """Instructions per cycle of one run of ``kind`` (cachegrind, twice against once)."""
    counts = []
    for times in (0, 1):
        command = [
            "setarch", "-R", "valgrind", "--tool=cachegrind", "--cache-sim=no",
            "--cachegrind-out-file=/dev/null", sys.executable, __file__,
            "--count", str(log), str(behaviors), str(fields), kind, str(times),
        ]  # fmt: skip
        env = {**os.environ, "PYTHONHASHSEED": "0", **QUIET_THREADS}
        done = subprocess.run(command, capture_output=True, text=True, env=env, check=False)
        found = _IREFS.search(done.stderr)
        if done.returncode != 0 or found is None:
            raise RuntimeError(f"valgrind {kind} failed: {done.stderr[-2000:]}")
        counts.append(int(found.group(1).replace(",", "")))
    return (counts[1] - counts[0]) / cycles


# -- the grid -------------------------------------------------------------------------------


class Cell(NamedTuple):
    behaviors: int
    fields: int


def parse_grid(text: str) -> list[Cell]:
    """``10x10,10x1000`` (B x F) or ``all``."""
    if text == "all":
        return [Cell(b, f) for b in GRID for f in GRID]
    cells = []
    for item in text.split(","):
        b, _, f = item.partition("x")
        cells.append(Cell(int(b), int(f)))
    return cells


def measure_cell(cell: Cell, args: argparse.Namespace, directory: Path) -> Figures:
    behaviors, fields = cell
    log = directory / f"wide-{behaviors}x{fields}.beatlog"
    figures: Figures = {"behaviors": behaviors, "fields": fields, "cycles": args.cycles}
    figures["record"] = record(log, behaviors, fields, args.cycles)
    figures["build_us"] = build_costs(fields)
    cpu_figures = replay_against_bare(log, maker(behaviors, fields), args.rounds)
    figures["cpu"] = {
        key: cpu_figures[key]
        for key in (
            "replay_ok",
            "same_final_states",
            "replay_us_per_cycle",
            "bare_us_per_cycle",
            "replay_over_bare",
            "checked_over_bare",
            "round_ratios",
            "replay_speedup_best",
        )
    }
    if args.paced:
        figures["paced"] = paced(directory, behaviors, fields, args.paced)
    if args.split:
        figures["split"] = read_split(log, behaviors, fields, args.rounds)
    if args.instructions:
        kinds = COUNTED if args.split else ("replay", "bare")
        figures["instructions"] = {
            kind: instructions(log, behaviors, fields, kind, args.cycles) for kind in kinds
        }
    return figures


def read_split(log: Path, behaviors: int, fields: int, rounds: int) -> Figures:
    """CPU µs per cycle of reading the log in parts, alternated ``rounds`` times, medians.

    Chunks alone: zstd decompression, CRC. Batches: read with RS_t kept as bytes
    (msgspec skips it), decoded whole into the robot state type, into the checking type
    replay decodes with (:func:`~beatlog.replay.fit.schema.recorded_state_type`), and into a
    narrow struct of the fields read (unknown fields skipped). Robot states alone, their
    bytes taken out beforehand: decoded whole, narrow, as an untyped dict; the same
    values encoded as an array (a positional encoding, which the format does not have)
    decoded whole; and encoded by columns, one msgpack array per field and 256 cycles
    (a columnar layout, which the format does not have either), of which only the
    columns of the fields read are decoded and made into narrow states. Then one replay
    and one bare loop. Also the states' bytes per cycle, zstd-compressed, each way.
    """
    import zstandard  # noqa: PLC0415 - only this part reads chunks itself
    from mcap.records import Chunk  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    from beatlog.replay.fit.schema import recorded_state_type  # noqa: PLC0415

    with log.open("rb") as file:
        chunks = [r for r in StreamReader(file, emit_chunks=True).records if isinstance(r, Chunk)]
    decompressor = zstandard.ZstdDecompressor()
    opened = [decompressor.decompress(c.data, max_output_size=c.uncompressed_size) for c in chunks]
    with SessionLogReader(log) as reader:
        header = reader.header
        encoded = [bytes(record.robot_state) for record in reader.cycles()]
    state = wide_state(fields)
    checking = recorded_state_type(header, state)
    narrow = narrow_state(behaviors, fields)
    positional: type[msgspec.Struct] = msgspec.defstruct(
        f"Positional{fields}",
        [(f.name, f.type) for f in msgspec.structs.fields(state)],
        array_like=True,
    )
    decode_full = msgspec.msgpack.Decoder(state).decode
    as_array = [
        msgspec.msgpack.encode(positional(*msgspec.structs.astuple(decode_full(b))))
        for b in encoded
    ]
    decoded = [decode_full(b) for b in encoded]
    groups = [decoded[start : start + 256] for start in range(0, len(decoded), 256)]
    columns = [
        [
            msgspec.msgpack.encode([getattr(one, name) for one in group])
            for name in state.__struct_fields__
        ]
        for group in groups
    ]
    read_at = [state.__struct_fields__.index(name) for name in narrow.__struct_fields__]
    decode_column = msgspec.msgpack.Decoder(list[Any]).decode

    def columnar() -> None:
        for group in columns:
            list(map(narrow, *[decode_column(group[index]) for index in read_at]))

    decode_narrow = msgspec.msgpack.Decoder(narrow).decode
    decode_dict = msgspec.msgpack.Decoder(dict[str, Any]).decode
    decode_array = msgspec.msgpack.Decoder(positional).decode
    runs = counted_runs(log, behaviors, fields)
    parts: dict[str, Callable[[], object]] = {
        "decompress": lambda: [decompressor.decompress(c.data) for c in chunks],
        "crc": lambda: [zlib.crc32(data) for data in opened],
        "read": runs["read"],
        "read-decode": runs["read-decode"],
        "read-checking": lambda: _read_log(log, checking),
        "read-narrow": runs["read-narrow"],
        "state-decode": lambda: [decode_full(b) for b in encoded],
        "state-narrow": lambda: [decode_narrow(b) for b in encoded],
        "state-dict": lambda: [decode_dict(b) for b in encoded],
        "state-array": lambda: [decode_array(b) for b in as_array],
        "state-columns-read": columnar,
        "replay": runs["replay"],
        "bare": runs["bare"],
    }
    times: dict[str, list[float]] = {name: [] for name in parts}
    for _ in range(rounds):
        for name, run in parts.items():
            times[name].append(cpu(run)[0])
    cycles = len(encoded)
    split: Figures = {
        name: statistics.median(spent) / cycles * 1e6 for name, spent in times.items()
    }
    split["fields_read"] = len(fields_read(behaviors, fields))
    split["map_bytes_per_state"] = statistics.fmean(map(len, encoded))
    split["array_bytes_per_state"] = statistics.fmean(map(len, as_array))
    for name, parts_of in (
        ("map", encoded),
        ("array", as_array),
        ("columns", [column for group in columns for column in group]),
    ):
        split[f"{name}_zstd_bytes_per_state"] = len(zstandard.compress(b"".join(parts_of))) / cycles
    return split


# -- report ----------------------------------------------------------------------------------


def report(figures: Figures) -> list[str]:
    """One line per measured part of a cell."""
    cell = f"B={figures['behaviors']}, F={figures['fields']}"
    rec, cpu_f = figures["record"], figures["cpu"]
    lines = [
        f"{cell}: {figures['cycles']} cycles, {rec['bytes_per_cycle']:.0f} bytes/cycle, "
        f"{rec['state_changes_per_cycle']:.2f} state changes/cycle",
        f"  CPU replay / bare {cpu_f['replay_over_bare']:.2f} "
        f"({cpu_f['replay_us_per_cycle']:.1f} / {cpu_f['bare_us_per_cycle']:.1f} µs/cycle; "
        f"rounds {cpu_f['round_ratios'][0]:.2f}-{cpu_f['round_ratios'][-1]:.2f}); "
        f"checked / bare {cpu_f['checked_over_bare']:.2f}; ok {cpu_f['replay_ok']}, "
        f"same states {cpu_f['same_final_states']}",
        f"  Recorder.step p50/p99 {rec['recorder_step_us']['p50']:.1f}/"
        f"{rec['recorder_step_us']['p99']:.1f} µs; executor alone "
        f"{rec['executor_step_us']['p50']:.1f}/{rec['executor_step_us']['p99']:.1f} µs",
        "  build one state (µs): "
        + ", ".join(f"{k} {v:.1f}" for k, v in figures["build_us"].items()),
    ]
    if "instructions" in figures:
        counted = figures["instructions"]
        lines.append(
            f"  instructions/cycle replay {counted['replay']:,.0f} / bare {counted['bare']:,.0f}"
            f" = {counted['replay'] / counted['bare']:.2f}"
            + "".join(f"; {kind} {counted[kind]:,.0f}" for kind in COUNTED[2:] if kind in counted)
        )
    if "paced" in figures:
        for name, part in figures["paced"].items():
            wall, cpu_us = part["wall_us"], part["cpu_us"]
            lines.append(
                f"  paced {name}: wall p50/p99/max {wall['p50']:.1f}/{wall['p99']:.1f}/"
                f"{wall['max']:.1f} µs, CPU p50/p99/max {cpu_us['p50']:.1f}/{cpu_us['p99']:.1f}/"
                f"{cpu_us['max']:.1f} µs, overruns {part['overruns']}"
            )
    if "split" in figures:
        lines.append(
            "  read split (µs/cycle): "
            + ", ".join(f"{k} {v:.1f}" for k, v in figures["split"].items())
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument(
        "--grid", default="all", help="cells as BxF,BxF (default: all of 10, 100, 1000)"
    )
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--no-instructions", dest="instructions", action="store_false")
    parser.add_argument("--split", action="store_true", help="also time reading the log in parts")
    parser.add_argument(
        "--paced", type=int, default=0, metavar="BEATS", help="also time BEATS live 30 ms beats"
    )
    parser.add_argument("--json", type=Path)
    parser.add_argument(
        "--count", nargs=5, metavar=("LOG", "B", "F", "KIND", "TIMES"), help=argparse.SUPPRESS
    )
    args = parser.parse_args()
    if args.count:
        log, behaviors, fields, kind, times = args.count
        count_child(Path(log), int(behaviors), int(fields), kind, int(times))
        return
    results = []
    with tempfile.TemporaryDirectory() as directory:
        for cell in parse_grid(args.grid):
            figures = measure_cell(cell, args, Path(directory))
            results.append(figures)
            print("\n".join(report(figures)), flush=True)
            if args.json:
                args.json.write_text(json.dumps(results, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
