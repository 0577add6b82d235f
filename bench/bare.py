"""Replay against a bare loop: what replay costs beyond running the behaviors themselves.

The bare loop updates a fresh system once per cycle of a log, with the same behaviors
and the same inputs as replay, decoded before any timing: the heartbeat intervals, the
robot states and the random numbers, handed out in order with no checks. It reads no
log, diffs no state, compares nothing and builds no context beyond the fields behaviors
read. Replay and the bare loop run alternately, timed in CPU time
(``time.process_time``), and the figure is the ratio of their medians.

A third loop, the checked loop (:func:`run_checked`), says how far replay could go in
Python: it reads the log as replay does (robot states decoded with their batch) and
makes the per-cycle checks of a passing cycle, and nothing else, in one flat loop: the
state changes and outputs compared with the recorded bytes, the random numbers loaded
and their count checked. It keeps no outcome, reports nothing and stops at nothing, so
its ratio to the bare loop is a floor for any pure-Python replay with these checks.

Used by ``bench_core.py`` (the rover) and ``bench_dog.py`` (the dog).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

import msgspec

import beatlog
from beatlog import ReplayResult
from beatlog.log.columns import StateColumns
from beatlog.log.format import EMPTY_LIST, EMPTY_MAP, payload_encoder
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.context import Context, Outputs
from beatlog.model.cycle import find_changes, state_reader
from beatlog.model.random import Draw
from beatlog.replay.random import ReplayRandom
from beatlog.replay.view import StateViews

__all__ = [
    "BareInputs",
    "final_states",
    "load_bare_inputs",
    "replay_against_bare",
    "replay_fresh",
    "run_bare",
    "run_checked",
]

T = TypeVar("T")


class BareRandom:
    """Hands out pre-decoded random values in order, with no checks."""

    __slots__ = ("_next",)

    def __init__(self, values: Sequence[Any]) -> None:
        self._next = iter(values).__next__

    def random(self) -> float:
        return self._next()  # type: ignore[no-any-return]

    def uniform(self, a: float, b: float) -> float:
        return self._next()  # type: ignore[no-any-return]

    def gauss(self, mu: float = 0.0, sigma: float = 1.0) -> float:
        return self._next()  # type: ignore[no-any-return]

    def randint(self, a: int, b: int) -> int:
        return int(self._next())

    def choice(self, seq: Sequence[T]) -> T:
        return seq[int(self._next())]


class BareContext:
    """What behaviors use of a context, and nothing else."""

    __slots__ = ("actor", "cycle", "dt_ns", "outputs", "random", "time_ns")

    def __init__(self, random: BareRandom) -> None:
        self.random = random
        self.cycle = -1
        self.time_ns = 0
        self.dt_ns = 0
        self.actor = -1
        self.outputs: Outputs = {}

    @property
    def dt(self) -> float:
        return self.dt_ns / 1e9

    def emit(self, name: str, value: Any) -> None:
        self.outputs[name] = value


@dataclass(frozen=True)
class BareInputs:
    """Every cycle's heartbeat interval and decoded robot state, and all draws in order."""

    heartbeat_ns: list[int]
    states: list[Any]
    draws: list[Any]


def load_bare_inputs(path: Path, robot_state: type[msgspec.Struct]) -> BareInputs:
    """Decode every cycle's HB, RS and RN from the log, before any timing."""
    decode_state = msgspec.msgpack.Decoder(robot_state).decode
    decode_draws = msgspec.msgpack.Decoder(list[Draw]).decode
    inputs = BareInputs([], [], [])
    with SessionLogReader(path) as reader:
        for record in reader.cycles():
            inputs.heartbeat_ns.append(record.heartbeat_ns)
            inputs.states.append(decode_state(record.robot_state))
            inputs.draws.extend(draw.value for draw in decode_draws(record.random_numbers))
    return inputs


def run_bare(inputs: BareInputs, make_system: Callable[[], System]) -> System:
    """Update a fresh system once per cycle from the pre-decoded inputs."""
    system = make_system()
    update = system.update
    bare = BareContext(BareRandom(inputs.draws))
    context = cast(Context, bare)
    time_ns = 0
    for cycle, (hb_ns, state) in enumerate(zip(inputs.heartbeat_ns, inputs.states, strict=True)):
        time_ns += hb_ns
        bare.cycle = cycle
        bare.time_ns = time_ns
        bare.dt_ns = hb_ns
        bare.actor = -1
        bare.outputs = {}
        update(state, context)
    return system


def run_checked(path: Path, make_system: Callable[[], System]) -> System:
    """Replay ``path`` with a passing cycle's checks alone, in one flat loop; a cycle
    that does not pass them is counted, and the count must be zero."""
    system = make_system()
    update = system.update
    random = ReplayRandom()
    context = Context(random)
    random.bind(context)
    read_states = state_reader(tuple(system.behaviors.values()))
    states = read_states()
    encode = payload_encoder().encode
    decode_draws = msgspec.msgpack.Decoder(list[Draw]).decode
    raw = msgspec.Raw
    now_ns = failed = 0
    with SessionLogReader(path) as reader:
        reader.decode_states(system.robot_state)
        view = StateViews(system.robot_state, system.robot_state, path).view
        for batch in reader.batches():
            for record in batch:
                context.cycle += 1
                context.dt_ns = interval = record.heartbeat_ns
                context.time_ns = now_ns = now_ns + interval
                context.actor = -1
                if context.outputs:
                    context.outputs = {}
                draws = record.random_numbers
                if draws != EMPTY_LIST or random.recorded:
                    random.load(() if draws == EMPTY_LIST else decode_draws(draws))
                state: Any = record.robot_state
                if state.__class__ is StateColumns:  # format 3: a view of the columns
                    state = view(state, context.cycle)
                update(state, context)
                now = read_states()
                if now != states:
                    changes = find_changes(now, states)
                    failed += record.state_changes != raw(encode(changes))
                else:
                    failed += record.state_changes != EMPTY_LIST
                outputs = context.outputs
                failed += (
                    record.outputs != raw(encode(outputs))
                    if outputs
                    else record.outputs != EMPTY_MAP
                )
                failed += random.refused is not None or len(random.drawn) != len(random.recorded)
    if failed:
        raise AssertionError(f"{path}: {failed} cycles failed the checked loop")
    return system


def final_states(system: System) -> dict[str, Any]:
    """Every behavior's state, by catalogue id."""
    return {name: behavior.state for name, behavior in system.behaviors.items()}


def cpu(run: Callable[[], T]) -> tuple[float, T]:
    """Run ``run`` once; its CPU time in seconds and its result."""
    started = time.process_time()
    result = run()
    return time.process_time() - started, result


def replay_fresh(path: Path, make_system: Callable[[], System]) -> tuple[ReplayResult, System]:
    """Replay ``path`` against a fresh system; the result and the system."""
    system = make_system()
    return beatlog.replay(path, system), system


def replay_against_bare(
    path: Path, make_system: Callable[[], System], rounds: int
) -> dict[str, Any]:
    """Replay ``path`` and run the bare loop on it alternately, ``rounds`` times each."""
    inputs = load_bare_inputs(path, make_system().robot_state)
    cycles = len(inputs.states)
    replays: list[tuple[float, tuple[ReplayResult, System]]] = []
    bares: list[tuple[float, System]] = []
    checked: list[tuple[float, System]] = []
    for _ in range(rounds):
        replays.append(cpu(lambda: replay_fresh(path, make_system)))
        bares.append(cpu(lambda: run_bare(inputs, make_system)))
        checked.append(cpu(lambda: run_checked(path, make_system)))
    replay_s = statistics.median(run[0] for run in replays)
    bare_s = statistics.median(run[0] for run in bares)
    checked_s = statistics.median(run[0] for run in checked)
    results = [result for _, (result, _) in replays]
    return {
        "cycles": cycles,
        "rounds": rounds,
        "replay_ok": all(result.ok and result.cycles == cycles for result in results),
        "replay_cpu_s": [run[0] for run in replays],
        "bare_cpu_s": [run[0] for run in bares],
        "replay_us_per_cycle": replay_s / cycles * 1e6,
        "bare_us_per_cycle": bare_s / cycles * 1e6,
        "replay_cycles_per_s": cycles / replay_s,
        "replay_speedup_best": max(result.speedup for result in results),
        "replay_speedup_median": statistics.median(result.speedup for result in results),
        "replay_over_bare": replay_s / bare_s,
        "checked_us_per_cycle": checked_s / cycles * 1e6,
        "checked_over_bare": checked_s / bare_s,
        "round_ratios": sorted(a[0] / b[0] for a, b in zip(replays, bares, strict=True)),
        "same_final_states": all(
            final_states(replayed) == final_states(bare) == final_states(flat)
            for (_, (_, replayed)), (_, bare), (_, flat) in zip(
                replays, bares, checked, strict=True
            )
        ),
    }
