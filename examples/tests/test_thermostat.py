"""The thermostat: recorded from inside its own loop, replayed, and its planted bug caught."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from beatlog import DivergenceKind, StateChange, replay
from beatlog.analysis.summary import summarize
from beatlog.analysis.trace import replayed_trace
from beatlog.log.reader import SessionLogReader
from beatlog_examples.thermostat import Climate, changed_system, record, system
from beatlog_examples.thermostat.__main__ import main
from beatlog_examples.thermostat.controller import BAND

BOOST = [("idle", "boosting"), ("boosting", "resting"), ("resting", "idle")]
"""One boost: started by a cold room, over after its random while, ready again once warm."""


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two hours of the room: cold at first, its window open for five minutes at 1 h."""
    return record(tmp_path_factory.mktemp("thermostat") / "room.beatlog", hours=2.0, seed=4)


def climates(log: Path) -> list[Climate]:
    """The robot states of ``log``, as recorded."""
    with SessionLogReader(log) as reader:
        reader.decode_states(Climate)
        states: list[Any] = [cycle.robot_state for cycle in reader.cycles()]
    return states


def test_a_session_recorded_from_the_thermostat_s_own_loop_replays_and_passes(
    session: Path,
) -> None:
    result = replay(session, system())

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 720, "state_changes": 23, "outputs": 720, "draws": 2, "samples": 0},
    )
    assert result.cycles == 720
    summary = summarize(session)
    assert summary.heartbeat_mean_ms == 10_000.0  # each beat measured on the room's clock
    assert summary.end is not None
    assert summary.end.overruns == 0


def test_the_session_boosts_twice_at_random_lengths_and_the_heater_keeps_its_band(
    session: Path,
) -> None:
    changes = [traced.change for traced in replayed_trace(session, system()).changes]

    assert [(c.before, c.after) for c in changes if c.behavior == "boost"] == BOOST * 2
    assert summarize(session).random_draws == {"uniform": 2}
    heater = [(c.before, c.after) for c in changes if c.behavior == "heater"]
    assert len(heater) >= 8
    assert heater == [("off", "on"), ("on", "off")] * (len(heater) // 2) + [("off", "on")] * (
        len(heater) % 2
    )


def test_the_planted_bug_is_caught_where_the_heater_first_turns_on_inside_its_band(
    session: Path,
) -> None:
    switched = {
        traced.cycle: traced.change.after
        for traced in replayed_trace(session, system()).changes
        if traced.change.behavior == "heater"
    }
    heater, inside = "off", None
    for cycle, climate in enumerate(climates(session)):
        in_band = climate.setpoint - BAND <= climate.temperature < climate.setpoint + BAND
        if heater == "off" and in_band:
            inside = cycle
            break
        heater = switched.get(cycle, heater)

    divergence = replay(session, changed_system()).divergence

    assert divergence is not None
    assert divergence.kind is DivergenceKind.STATE_CHANGES
    assert divergence.cycle == inside
    assert divergence.expected == ()
    assert divergence.actual == (StateChange("heater", "off", "on"),)
    assert divergence.expected_outputs == {"heater": 0.0}
    assert divergence.actual_outputs == {"heater": 0.6}


def test_python_m_records_the_thermostat_once_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "thermostat.beatlog"

    main(["-o", str(log), "--hours", "0.5", "--seed", "1"])
    with pytest.raises(SystemExit) as again:
        main(["-o", str(log), "--hours", "0.5", "--seed", "1"])

    assert again.value.code == 2
    assert capsys.readouterr() == (
        f"wrote {log}\n",
        f"{log}: exists already; give a new file name\n",
    )

    result = replay(log, system())
    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 180, "state_changes": 7, "outputs": 180, "draws": 1, "samples": 0},
    )
    assert result.cycles == 180
    with SessionLogReader(log) as reader:
        assert reader.header.system == "beatlog_examples.thermostat:system"
        assert reader.header.robot_state_type == "beatlog_examples.thermostat.controller.Climate"
