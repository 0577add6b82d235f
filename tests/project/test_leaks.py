"""The leak watch: wall-clock reads and global random calls, each named by call and site."""

from __future__ import annotations

import datetime
import os
import random
import secrets
import site
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import beatlog
from beatlog.model.context import Context
from beatlog.model.random import RecordingRandom
from beatlog.project.leaks import Finding, LeakScreen, LeakWatch, built_watched
from tests.conftest import Near, Probe, RecordFn, probe_system
from tests.systems import (
    Disciplined,
    Leaky,
    drifter_sites,
    drifter_system,
    leaks,
    seeded_drifter_system,
)


@pytest.fixture
def context() -> Context:
    random = RecordingRandom(seed=1)
    context = Context(random)
    random.bind(context)
    return context


def test_every_leak_is_one_finding_naming_its_call_and_line(context: Context) -> None:
    with LeakWatch() as watch:
        Leaky().step(Probe(), context)

    assert watch.findings() == [Finding(call, where, 1) for call, where in leaks()]


def test_findings_count_the_calls_over_every_update(context: Context) -> None:
    watch = LeakWatch()
    leaky = Leaky()
    for _ in range(3):
        with watch:
            leaky.step(Probe(), context)

    assert {finding.count for finding in watch.findings()} == {3}
    assert len(watch.findings()) == len(leaks())


def test_time_and_chance_from_the_context_logging_and_private_generators_are_no_leaks(
    context: Context,
) -> None:
    with LeakWatch() as watch:
        for cycle in range(20):
            context.cycle = cycle
            Disciplined().step(Probe(), context)

    assert watch.findings() == []


def test_calls_outside_the_watch_or_by_the_frame_that_entered_it_are_not_counted(
    context: Context,
) -> None:
    watch = LeakWatch()
    Leaky().step(Probe(), context)
    with watch:
        time.monotonic()
        np.random.rand()
    Leaky().step(Probe(), context)

    assert watch.findings() == []


def test_the_frameworks_own_clock_reads_are_not_leaks(record_probe: RecordFn) -> None:
    log = record_probe(100)

    with LeakWatch() as watch:
        result = beatlog.replay(log, probe_system())  # times itself with time.perf_counter

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 100, "state_changes": 15, "outputs": 151, "draws": 20, "samples": 0},
    )
    assert watch.findings() == []


def drift() -> float:
    heading = float(np.random.normal())
    heading += 1.0
    return heading + steady()


def steady() -> float:
    return 0.0


def test_a_numpy_draw_is_placed_on_its_line_not_where_the_next_event_happens() -> None:
    draw = drift.__code__.co_firstlineno + 1

    with LeakWatch() as watch:
        drift()

    assert watch.findings() == [Finding("numpy.random", f"{__file__}:{draw} in drift", 1)]


@pytest.fixture
def pcg64_global_generator() -> Iterator[None]:
    legacy = np.random.mtrand.get_bit_generator()
    np.random.mtrand.set_bit_generator(np.random.PCG64(5))
    yield
    np.random.mtrand.set_bit_generator(legacy)


@pytest.mark.usefixtures("pcg64_global_generator")
def test_a_global_numpy_generator_other_than_mt19937_is_watched_too(context: Context) -> None:
    with LeakWatch() as watch:
        Leaky().step(Probe(), context)

    assert ("numpy.random", dict(leaks())["numpy.random"]) in [
        (finding.call, finding.site) for finding in watch.findings()
    ]


def test_an_installed_packages_line_is_the_site_with_the_user_code_that_led_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    installed = tmp_path / "site-packages"
    (installed / "treelib").mkdir(parents=True)
    (installed / "treelib" / "__init__.py").write_text(
        "import time\n\ndef tick():\n    return time.time()\n", encoding="utf-8"
    )
    monkeypatch.setattr(site, "getsitepackages", lambda: [str(installed)])
    monkeypatch.syspath_prepend(str(installed))
    monkeypatch.delitem(sys.modules, "treelib", raising=False)
    import treelib  # type: ignore[import-not-found]  # noqa: PLC0415 - installed by this test

    with LeakWatch() as watch:
        treelib.tick()
    with LeakWatch() as through_user_code:
        tick_tree(treelib.tick)

    site_ = f"{installed / 'treelib' / '__init__.py'}:4 in tick"
    assert watch.findings() == [Finding("time.time", site_, 1)]
    call = tick_tree.__code__.co_firstlineno + 1
    assert through_user_code.findings() == [
        Finding("time.time", site_, 1, via=f"{__file__}:{call} in tick_tree")
    ]


def tick_tree(tick: Callable[[], float]) -> float:
    return tick()


SCREENED: dict[str, Callable[[], object]] = {
    "time.monotonic": time.monotonic,
    "time.time_ns": time.time_ns,
    "time.clock_gettime": lambda: time.clock_gettime(time.CLOCK_REALTIME),
    "datetime.now": datetime.datetime.now,
    "date.today": datetime.date.today,
    "random.random": random.random,
    "random.choice": lambda: random.choice([1, 2]),
    "random.shuffle": lambda: random.shuffle([1, 2]),
    "os.urandom": lambda: os.urandom(2),
    "secrets": lambda: secrets.token_hex(2),
    "uuid.uuid4": uuid.uuid4,
    "numpy.random": np.random.rand,
}


@pytest.mark.parametrize("call", SCREENED.values(), ids=SCREENED)
def test_the_screen_sees_every_watched_call(call: Callable[[], object]) -> None:
    screen = LeakScreen()
    with screen:
        call()

    assert screen.suspicious
    assert screen.findings() == []  # where and how often is the watch's job


def test_the_screen_passes_updates_that_take_nothing_from_outside(context: Context) -> None:
    screen = LeakScreen()
    near = Near()
    for cycle in range(20):
        context.cycle = cycle
        with screen:
            near.step(Probe(distance=cycle / 20), context)

    assert not screen.suspicious


def test_calls_outside_the_screen_are_not_seen(context: Context) -> None:
    screen = LeakScreen()
    time.time()
    with screen:
        Near().step(Probe(), context)
    random.random()

    assert not screen.suspicious


def test_a_generator_the_set_up_made_without_a_seed_is_named_where_it_draws(
    context: Context,
) -> None:
    made, drawn = drifter_sites()
    system, generators = built_watched(drifter_system)
    watch = LeakWatch()
    watch.generators = generators

    for _ in range(3):
        with watch:
            system.update(Probe(), context)

    call = f"unseeded numpy.random.Generator made at {made}"
    assert [generator.name for generator in generators] == [call]
    assert watch.findings() == [Finding(call, drawn, 3)]


def test_a_generator_is_found_beside_a_big_state_in_a_big_process() -> None:
    def build() -> object:
        system = drifter_system()
        system.history = [float(beat) for beat in range(300_000)]  # type: ignore[attr-defined]
        return system

    made, _ = drifter_sites()
    _, generators = built_watched(build)

    assert [generator.name for generator in generators] == [
        f"unseeded numpy.random.Generator made at {made}"
    ]


def test_a_generator_the_set_up_seeded_is_no_leak(context: Context) -> None:
    system, generators = built_watched(seeded_drifter_system)
    watch = LeakWatch()
    watch.generators = generators

    with watch:
        system.update(Probe(), context)

    assert generators == []
    assert watch.findings() == []


def test_the_screen_sees_a_generator_the_set_up_made_without_a_seed(context: Context) -> None:
    system, generators = built_watched(drifter_system)
    screen = LeakScreen()
    screen.generators = generators

    with screen:
        system.update(Probe(), context)

    assert screen.suspicious
    assert screen.numpy_moved
