"""Factories shared by the tests: a tiny system and logs recorded from it in tmp_path."""

from __future__ import annotations

import bdb
import functools
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from beatlog.log.writer import SessionLogWriter
from beatlog.model.behavior import BehaviorState, PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.state import RobotState
from beatlog.record.recorder import Recorder
from beatlog.suite.log_cache import CACHE_DIR_VARIABLE
from tests.commands import Beatlog, Run
from tests.served import LogServer, serve

pytest_plugins = ["pytester"]

PERIOD_NS = 30_000_000


class Probe(RobotState, kw_only=True):
    """A robot state with one range reading and a float that may hold NaN or inf."""

    distance: float = 1.0
    reading: float = 0.0


class Near:
    """Goes 'near' when the distance drops below a threshold; asks for control then."""

    name = "near"

    def __init__(self, threshold: float = 0.5) -> None:
        self.state: BehaviorState = "far"
        self.threshold = threshold

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        self.state = "near" if rs.distance < self.threshold else "far"
        return {"speed": 0.0} if self.state == "near" else None


class Dice:
    """Draws one uniform number every ``every`` cycles; its state is the parity of a die."""

    name = "dice"

    def __init__(self, every: int = 5, draws: int = 1) -> None:
        self.state: BehaviorState = "even"
        self.every = every
        self.draws = draws

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        if ctx.cycle % self.every == 0:
            for _ in range(self.draws):
                roll = ctx.random.randint(1, 6)
            self.state = "odd" if roll % 2 else "even"
        return {"speed": 0.5, "time": ctx.time}


def probe_system(
    threshold: float = 0.5, *, every: int = 5, draws: int = 1
) -> PriorityArbiter[Probe]:
    """A two-behavior system: near (priority) and dice (random)."""
    return PriorityArbiter([Near(threshold), Dice(every, draws)], robot_state=Probe)


def distances(cycles: int) -> list[float]:
    """A distance profile that approaches and leaves an obstacle twice."""
    return [abs(((t % 100) - 50) / 50) for t in range(cycles)]


def first_cycle_below(threshold: float, cycles: int = 300) -> int:
    """The first cycle where the distance profile drops below ``threshold``."""
    return next(t for t, d in enumerate(distances(cycles)) if d < threshold)


RecordFn = Callable[..., Path]


@pytest.fixture(scope="session", autouse=True)
def session_log_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The cache of logs behind URLs in a folder of the test session's, never the
    user's: worker processes that a module's fixture starts inherit it."""
    folder = tmp_path_factory.mktemp("log-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_DIR_VARIABLE, str(folder))
        yield folder


@pytest.fixture(autouse=True)
def log_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Each test's own cache of logs behind URLs: what one test downloads, another
    downloads too."""
    folder = tmp_path_factory.mktemp("log-cache")
    monkeypatch.setenv(CACHE_DIR_VARIABLE, str(folder))
    return folder


@pytest.fixture
def record_probe(tmp_path: Path) -> RecordFn:
    """Record a probe session of ``cycles`` cycles and return its path."""

    def record(
        cycles: int = 300,
        *,
        name: str = "probe.beatlog",
        states: Sequence[Probe] | None = None,
        seed: int = 7,
        **options: object,
    ) -> Path:
        path = tmp_path / name
        feed = states if states is not None else [Probe(distance=d) for d in distances(cycles)]
        options = {"system_ref": "tests.conftest:probe_system", **options}
        with Recorder(
            path,
            probe_system(),
            seed=seed,
            software="test",
            **options,  # type: ignore[arg-type]
        ) as recorder:
            for t, state in enumerate(feed):
                recorder.step(PERIOD_NS + (t % 3) * 1000, state)
        return path

    return record


@pytest.fixture
def served(tmp_path: Path, record_probe: RecordFn) -> Iterator[LogServer]:
    """``served/`` with two probe sessions, ``dock.beatlog`` (300 cycles) and
    ``yard.beatlog`` (200), served over HTTP on the loopback."""
    (tmp_path / "served").mkdir()
    record_probe(300, name="served/dock.beatlog")
    record_probe(200, name="served/yard.beatlog")
    with serve(tmp_path / "served") as server:
        yield server


@pytest.fixture
def record_chunked(record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch) -> RecordFn:
    """Like ``record_probe``, but with a chunk every 10 cycles, so a cut keeps most cycles."""
    monkeypatch.setattr(
        "beatlog.record.recorder.SessionLogWriter",
        functools.partial(SessionLogWriter, batch_cycles=10, chunk_size=1),
    )
    return record_probe


def probe_system_changed() -> PriorityArbiter[Probe]:
    """The probe system with ``near`` reacting earlier: a deliberate behavior change."""
    return probe_system(threshold=0.6)


class Close(Near):
    """``near`` under a new name: a rename that changes no behavior."""

    name = "close"


def probe_system_renamed() -> PriorityArbiter[Probe]:
    """The probe system with ``near`` renamed to ``close``."""
    return PriorityArbiter([Close(), Dice()], robot_state=Probe)


def broken_probe() -> PriorityArbiter[Probe]:
    """A system factory that fails: the user's code raises while building the system."""
    raise RuntimeError("the arena map is missing")


MEETING = "BEATLOG_TEST_MEETING"
"""The environment variable naming the folder where meeting systems sign in."""


def meeting_system(processes: int = 2) -> PriorityArbiter[Probe]:
    """The probe system, built only once ``processes`` processes have built one: each signs
    in to the folder ``$BEATLOG_TEST_MEETING`` names with a file named after its pid that
    lists its imported modules, then waits (up to a minute) for the others. Specs of it
    finish only when they run at once, in as many processes."""
    folder = Path(os.environ[MEETING])
    (folder / str(os.getpid())).write_text("\n".join(sorted(sys.modules)))
    deadline = time.monotonic() + 60
    while len(list(folder.iterdir())) < processes and time.monotonic() < deadline:
        time.sleep(0.01)
    return probe_system()


@pytest.fixture
def meeting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The folder where meeting systems sign in, for this process and its children."""
    folder = tmp_path / "meeting"
    folder.mkdir()
    monkeypatch.setenv(MEETING, str(folder))
    return folder


def alone_system() -> PriorityArbiter[Probe]:
    """A meeting system that meets no one: it signs in and goes on at once."""
    return meeting_system(processes=1)


def crashing_system() -> PriorityArbiter[Probe]:
    """The probe system, except that the first one a suite worker process builds ends that
    process, as a crash would (exit 3), marked by a file ``crashed`` in the folder
    ``$BEATLOG_TEST_MEETING`` names; the runner's own process waits for that crash first
    (up to a minute), so that a worker is the one that crashes."""
    crashed = Path(os.environ[MEETING]) / "crashed"
    if getattr(sys.modules["__main__"].__spec__, "name", None) == "beatlog.suite.worker":
        try:
            os.close(os.open(crashed, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            return probe_system()
        os._exit(3)
    deadline = time.monotonic() + 60
    while not crashed.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    return probe_system()


def dying_system() -> PriorityArbiter[Probe]:
    """A system factory that ends its process, as a crash would, a second into its set-up:
    by then what its worker did before has reached the scheduler (Dask's messages go out
    every few milliseconds, a crash at once could take the news of a finished DTC along)."""
    time.sleep(1)
    os._exit(3)


def interrupted_system() -> PriorityArbiter[Probe]:
    """A system factory interrupted as Ctrl-C interrupts a process, which reaches a
    worker through the audit interpreters it started."""
    raise KeyboardInterrupt


BREAKS: list[dict[str, Any]] = []
"""What :func:`record_breakpoint` saw at each stop of the replay debugger."""


def record_breakpoint() -> None:
    """A ``PYTHONBREAKPOINT`` hook for tests: notes the debugger's locals instead of stopping."""
    frame = sys._getframe(1)
    names = ("robot_state", "recorded_state", "recorded_changes", "recorded_draws", "system")
    seen = {name: frame.f_locals[name] for name in names}
    context = frame.f_locals["context"]  # noted now: it moves on with the replay
    seen.update(cycle=context.cycle, time_ns=context.time_ns, dt_ns=context.dt_ns)
    BREAKS.append(seen)


def quit_at_breakpoint() -> None:
    """A ``PYTHONBREAKPOINT`` hook for tests: a debugger built on bdb, quit at once."""
    raise bdb.BdbQuit


@pytest.fixture
def breaks(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[dict[str, Any]]]:
    """Every stop of the replay debugger in the test, noted by :func:`record_breakpoint`."""
    monkeypatch.setenv("PYTHONBREAKPOINT", "tests.conftest.record_breakpoint")
    BREAKS.clear()
    yield BREAKS
    BREAKS.clear()


@pytest.fixture
def beatlog(capsys: pytest.CaptureFixture[str]) -> Beatlog:
    """Any ``beatlog`` command, in process; ``test`` with one worker (a pool costs ~0.5 s).
    The command is imported when the fixture is used: specs name systems in this module,
    and a suite's workers import it, which must not load the CLI."""
    from beatlog.cli.main import main  # noqa: PLC0415 - see the docstring

    def run(*args: str | Path) -> Run:
        argv = [str(arg) for arg in args]
        if argv[:1] == ["test"]:
            argv[1:1] = ["-j", "1"]
        code = main(argv)
        captured = capsys.readouterr()
        return Run(code, captured.out, captured.err)

    return run
