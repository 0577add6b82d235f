"""The replay debugger: stop just before the behaviors update in a chosen cycle, with the
cycle's context and recording at hand, one step from the system's update; quitting it
stops the replay, and a break the replay never reaches is said."""

from __future__ import annotations

import inspect
import os
from pathlib import Path

import pytest

from beatlog.cli.main import main
from beatlog.log.reader import SessionLogReader
from beatlog.model import behavior
from beatlog.model.random import Draw
from beatlog.replay import debugger
from beatlog.replay.debugger import DebuggerQuit
from beatlog.replay.judge import replay
from tests.commands import at_a_terminal
from tests.conftest import Probe, RecordFn, probe_system, probe_system_changed
from tests.factories import cut_short
from tests.perceptions import changed_perception, record_with_samples
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE, PROBE
from tests.text import whole_lines

BANNER = (
    "beatlog: cycle 75 of probe.beatlog, t = 2.280 s (HB_t 30.000 ms), just before the "
    "behaviors update\n"
    "at hand: robot_state (RS_t), recorded_changes (BS_t), recorded_draws (RN_t), context, "
    "system\n"
    "`s` steps into system.update, `c` replays on, `q` stops\n"
)
"""What the debugger says first at a break in cycle 75 of a probe session."""


def heartbeats(log: Path) -> list[int]:
    """HB_t of every cycle of ``log``."""
    with SessionLogReader(log) as reader:
        return [record.heartbeat_ns for record in reader.cycles()]


def source_line(function: object, start: str) -> int:
    """The number of the line of ``function``'s source that starts with ``start``."""
    lines, first = inspect.getsourcelines(function)  # type: ignore[arg-type]
    return first + next(n for n, line in enumerate(lines) if line.strip().startswith(start))


def test_break_at_stops_before_the_update_with_the_cycle_at_hand(
    record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    log = record_probe(300)
    system = probe_system()

    assert replay(log, system, break_at=75).ok

    beats = heartbeats(log)
    assert breaks == [
        {
            "cycle": 75,
            "time_ns": sum(beats[:76]),  # the end of cycle 75's heartbeat
            "dt_ns": beats[75],
            "robot_state": Probe(distance=0.5),
            "recorded_state": Probe(distance=0.5),
            "recorded_changes": [
                ("arbiter", "near", "dice"),
                ("near", "near", "far"),
                ("dice", "odd", "even"),
            ],
            "recorded_draws": [Draw(actor=2, kind="randint", value=4, params=(1, 6))],
            "system": system,
        }
    ]


def test_the_banner_says_where_replay_stopped_and_what_is_at_hand(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    replay(record_probe(300), probe_system(), break_at=75)

    assert capsys.readouterr().err == BANNER  # on stderr for a debugger of its own


def test_a_break_changes_nothing_in_the_replay(
    record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    log = record_probe(300)

    stopped = replay(log, probe_system_changed(), break_at=FIRST_CHANGED_CYCLE)
    straight = replay(log, probe_system_changed())

    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]
    assert stopped.divergence == straight.divergence
    assert (stopped.cycles, stopped.checked) == (straight.cycles, straight.checked)


def test_break_on_divergence_stops_at_the_first_divergence(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    log = record_probe(300)
    code = main(["replay", str(log), "--system", CHANGED, "--break-on-divergence"])
    assert code == 1
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]
    assert "first divergence: cycle 21, t = 0.660 s, state changes" in whole_lines(
        capsys.readouterr().out
    )


def test_without_a_break_the_debugger_is_never_entered(
    record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    assert replay(record_probe(50), probe_system()).ok
    assert breaks == []


def test_pythonbreakpoint_0_turns_the_stop_and_its_banner_off(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("PYTHONBREAKPOINT", "0")

    assert replay(record_probe(300), probe_system(), break_at=75).ok
    assert capsys.readouterr().err == ""


def test_in_sensor_level_replay_the_recorded_state_is_at_hand_beside_the_rebuilt_one(
    tmp_path: Path, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    log = record_with_samples(tmp_path / "samples.beatlog")

    replay(log, probe_system(), perception=changed_perception(), break_at=0, keep_going=True)

    [stop] = breaks
    assert (stop["robot_state"], stop["recorded_state"]) == (
        Probe(distance=1.1),  # what the changed perception rebuilt: the behaviors get it
        Probe(distance=1.0),
    )
    assert capsys.readouterr().err.splitlines()[1] == (
        "at hand: robot_state (RS_t rebuilt from the samples), recorded_state (RS_t as "
        "recorded), recorded_changes (BS_t), recorded_draws (RN_t), context, system"
    )


def test_quitting_another_debugger_at_the_break_stops_the_replay(
    record_probe: RecordFn, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PYTHONBREAKPOINT", "tests.conftest.quit_at_breakpoint")

    with pytest.raises(DebuggerQuit, match=r"^stopped in the debugger$"):
        replay(record_probe(300), probe_system(), break_at=75)


def test_a_break_past_the_end_of_the_log_is_a_usage_error(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    log = record_probe(300)

    code = main(["replay", str(log), "--system", PROBE, "--break-at", "300"])

    assert (code, capsys.readouterr().err) == (
        2,
        f"beatlog: error: --break-at 300: {log} has only 300 cycles; no break would be reached\n",
    )
    assert breaks == []


def test_a_break_past_the_end_of_a_log_cut_off_is_noted_after_the_replay(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    cut = cut_short(record_probe(300, flush_interval_s=1.0))  # no end record counts them
    cycles = replay(cut, probe_system(), allow_truncated=True).cycles

    code = main(["replay", str(cut), "--system", PROBE, "--break-at", "1000", "--allow-truncated"])

    assert code == 0
    assert (
        f"note: the break at cycle 1000 was never reached: the log has only {cycles} cycles"
        in capsys.readouterr().out.splitlines()
    )
    assert breaks == []


def test_break_on_divergence_at_the_end_of_a_log_cut_off_notes_there_is_no_cycle_to_stop_in(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    cut = cut_short(record_probe(300, flush_interval_s=1.0))
    cycles = replay(cut, probe_system(), allow_truncated=True).cycles

    code = main(["replay", str(cut), "--system", PROBE, "--break-on-divergence"])

    assert code == 1  # the log ends early
    assert (
        f"note: the break at cycle {cycles} was never reached: the log has only {cycles} "
        "cycles" in capsys.readouterr().out.splitlines()
    )
    assert breaks == []


# pdb at a terminal, as a person uses it


@pytest.fixture
def debugging(record_probe: RecordFn) -> list[str | Path]:
    """``beatlog replay`` of a probe session with a break in cycle 75."""
    log = record_probe(300)
    return ["-m", "beatlog.cli.main", "replay", log, "--system", PROBE, "--break-at", "75"]


@pytest.fixture
def pdb_env() -> dict[str, str]:
    """The environment of a command that stops in pdb: no breakpoint hook of the tests."""
    return {key: value for key, value in os.environ.items() if key != "PYTHONBREAKPOINT"}


def test_pdb_stops_one_step_from_the_systems_update_with_the_cycles_context(
    debugging: list[str | Path], pdb_env: dict[str, str]
) -> None:
    beats = heartbeats(Path(debugging[3]))
    stop = source_line(debugger.pause, "update(robot_state, context)")
    update = source_line(behavior.PriorityArbiter.update, "def update(")

    with at_a_terminal(debugging, env=pdb_env) as terminal:
        first = terminal.until("(Pdb) ")
        context = terminal.type("p context.cycle, context.time_ns, context.dt_ns", until="(Pdb) ")
        stepped = terminal.type("s", until="(Pdb) ")
        code, rest = terminal.end("q")

    assert first == (
        f"{BANNER}> {debugger.__file__}({stop})pause()\n"
        "-> update(robot_state, context)  # `s` steps into system.update\n(Pdb) "
    )
    assert context == (
        "p context.cycle, context.time_ns, context.dt_ns\n"
        f"(75, {sum(beats[:76])}, {beats[75]})\n(Pdb) "
    )
    assert stepped == (
        f"s\n--Call--\n> {behavior.__file__}({update})update()\n"
        "-> def update(self, state: RS, context: Context) -> None:\n(Pdb) "
    )
    assert (code, rest) == (130, "q\nbeatlog: stopped in the debugger\n")


def test_quitting_pdb_after_stepping_past_the_update_stops_the_replay_cleanly(
    debugging: list[str | Path], pdb_env: dict[str, str]
) -> None:
    with at_a_terminal(debugging, env=pdb_env) as terminal:
        terminal.until("(Pdb) ")
        for _ in range(3):  # over the update, out of it, out of the executor's call
            terminal.type("n", until="(Pdb) ")
        code, rest = terminal.end("q")

    assert (code, rest) == (130, "q\nbeatlog: stopped in the debugger\n")


def test_continue_replays_on_to_the_verdict(
    debugging: list[str | Path], pdb_env: dict[str, str]
) -> None:
    with at_a_terminal(debugging, env=pdb_env) as terminal:
        terminal.until("(Pdb) ")
        code, rest = terminal.end("c")

    assert code == 0
    assert rest.splitlines()[1].startswith("PASS ")
