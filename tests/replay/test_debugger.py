"""The replay debugger: stop just before the behaviors update in a chosen cycle."""

from __future__ import annotations

import pytest

from beatlog.cli.main import main
from beatlog.replay.judge import replay
from tests.conftest import Probe, RecordFn, distances, probe_system
from tests.specs import CHANGED, FIRST_CHANGED_CYCLE


def test_break_at_stops_before_the_update_with_the_cycle_at_hand(
    record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    log = record_probe(300)
    assert replay(log, probe_system(), break_at=40).ok
    [stop] = breaks
    assert stop["cycle"] == 40
    assert stop["robot_state"] == Probe(distance=distances(300)[40])
    assert stop["system"] is not None
    assert stop["context_cycle"] == 39  # the context is not yet updated to cycle 40


def test_break_on_divergence_stops_at_the_first_divergence(
    record_probe: RecordFn, breaks: list[dict[str, object]], capsys: pytest.CaptureFixture[str]
) -> None:
    log = record_probe(300)
    code = main(["replay", str(log), "--system", CHANGED, "--break-on-divergence"])
    assert code == 1
    assert [stop["cycle"] for stop in breaks] == [FIRST_CHANGED_CYCLE]
    assert "first divergence" in capsys.readouterr().out


def test_without_a_break_the_debugger_is_never_entered(
    record_probe: RecordFn, breaks: list[dict[str, object]]
) -> None:
    assert replay(record_probe(50), probe_system()).ok
    assert breaks == []
