"""Variants: a recording replayed with deterministic perturbations, judged by the
behaviors not raising and by the invariants, never by the recording."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog import replay
from beatlog.errors import WindowError
from beatlog.project.usercode import load_system
from beatlog.replay.perturbation import Perturbations, Variant
from beatlog.replay.variant import replay_variant
from beatlog.replay.verdict import DivergenceKind
from tests.conftest import RecordFn, probe_system
from tests.perceptions import broken_perception, record_with_samples
from tests.perturbed import PERTURBED, Seen, replayed
from tests.systems import fussy_system


def test_a_behavior_that_raises_only_under_noise_fails_its_variant(
    record_probe: RecordFn,
) -> None:
    log = record_probe(100, start_time_ns=1_700_000_000_000_000_000)  # its variants keyed
    assert replay(log, fussy_system()).ok  # the recording never reaches the bug

    results = [replayed(log, n, system=fussy_system())[0] for n in range(1, 9)]

    failed = [result for result in results if not result.ok]
    assert failed
    divergence = failed[0].divergence
    assert divergence is not None
    assert divergence.kind is DivergenceKind.EXCEPTION
    assert divergence.message.startswith("near raised ValueError: a negative distance: -")
    assert divergence.robot_state["distance"] < 0
    assert "raise ValueError" in (divergence.traceback or "")
    assert failed[0].cycles == divergence.cycle + 1  # no cycle replayed past it


def test_unchanged_code_passes_every_variant(record_probe: RecordFn) -> None:
    log = record_probe(100)

    results = [replayed(log, n)[0] for n in range(1, 9)]

    assert all(result.ok for result in results)
    assert {result.cycles for result in results} == {100}
    assert all(result.checked.anything for result in results)
    assert all(result.checked.draws == 20 for result in results)  # fresh, counted too


def test_an_invariant_that_does_not_hold_fails_the_variant_there(
    record_probe: RecordFn,
) -> None:
    log = record_probe(100)
    seen = Seen()

    result = replay_variant(
        log,
        probe_system(),
        Variant(1, Perturbations()),
        invariants=["tests.systems:never_close"],
        observers=[lambda reader: seen],
    )

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.INVARIANT
    assert result.divergence.cycle == 35  # the first within 0.3 m of the pole
    assert result.cycles == len(seen.cycles) == 36


def test_invariants_that_hold_in_every_cycle_pass_the_variant(record_probe: RecordFn) -> None:
    log = record_probe(100)

    result = replay_variant(
        log, probe_system(), Variant(1, PERTURBED), invariants=[lambda cycle: cycle.dt_ns > 0]
    )

    assert result.ok
    assert result.cycles == 100


def test_a_log_cut_short_fails_a_variant_unless_allowed(record_probe: RecordFn) -> None:
    log = record_probe(100)
    data = log.read_bytes()
    log.write_bytes(data[: len(data) * 2 // 3])

    result = replay_variant(log, probe_system(), Variant(1, PERTURBED))
    allowed = replay_variant(log, probe_system(), Variant(1, PERTURBED), allow_truncated=True)

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.LOG_ENDED
    assert allowed.ok


def test_a_perception_step_that_raises_fails_the_variant(tmp_path: Path) -> None:
    log = record_with_samples(tmp_path / "sensed.beatlog", 100)

    result = replay_variant(
        log, probe_system(), Variant(1, Perturbations()), perception=broken_perception()
    )

    assert result.divergence is not None
    assert result.divergence.kind is DivergenceKind.PERCEPTION
    assert "no range sensor" in (result.divergence.traceback or "")


NOISY = Variant(1, Perturbations(noise={"distance": 0.3}))
"""A variant whose noise on ``distance`` makes the fussy probe raise."""


def test_a_window_perturbs_and_judges_its_cycles_alone(record_probe: RecordFn) -> None:
    log = record_probe(300)
    whole = replay_variant(log, fussy_system(), NOISY)
    assert whole.divergence is not None
    cycle = whole.divergence.cycle

    there = replay_variant(log, fussy_system(), NOISY, start_cycle=cycle, end_cycle=cycle)
    before = replay_variant(log, fussy_system(), NOISY, end_cycle=cycle - 1)
    after = replay_variant(log, fussy_system(), NOISY, start_cycle=cycle + 1, end_cycle=cycle + 1)

    assert there.divergence is not None
    assert (there.divergence.cycle, there.divergence.message, there.cycles) == (
        cycle,
        whole.divergence.message,  # the same noise in its cycle, however far it is read
        1,
    )
    assert (before.ok, before.cycles, before.status) == (True, cycle, None)
    # the cycle before the window is replayed unperturbed: it no longer fails there
    assert after.divergence is None or after.divergence.cycle == cycle + 1


def test_a_variant_from_a_fresh_start_fails_as_its_whole_replay_does_in_that_cycle(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    whole = replay_variant(log, fussy_system(), NOISY)
    assert whole.divergence is not None
    cycle = whole.divergence.cycle

    fresh = replay_variant(
        log, fussy_system(), NOISY, start_cycle=cycle - 10, end_cycle=cycle, fresh_start=True
    )

    assert fresh.divergence is not None
    assert (fresh.divergence.cycle, fresh.divergence.time_ns, fresh.divergence.message) == (
        cycle,
        whole.divergence.time_ns,  # the recorded time, the same noise in its cycle
        whole.divergence.message,
    )
    assert fresh.cycles == 11


def test_a_variant_that_raises_before_its_window_fails_there(record_probe: RecordFn) -> None:
    log = record_probe(300)
    fragile = load_system("tests.systems:fragile_system")

    result = replay_variant(log, fragile, NOISY, start_cycle=290, end_cycle=299)

    assert result.divergence is not None
    assert result.divergence.message == (
        "before the window (cycle 290 on): dice raised ZeroDivisionError: fragile dice"
    )


def test_a_variant_window_past_the_log_is_an_error(record_probe: RecordFn) -> None:
    log = record_probe(30)

    with pytest.raises(WindowError) as raised:
        replay_variant(log, probe_system(), NOISY, end_cycle=30)

    assert str(raised.value) == f"{log}: end_cycle 30 is past the log's last cycle (29)"


def test_a_variant_window_past_a_log_cut_short_is_an_error_as_in_a_replay(
    record_probe: RecordFn,
) -> None:
    log = record_probe(100)
    data = log.read_bytes()
    log.write_bytes(data[: len(data) * 2 // 3])

    with pytest.raises(WindowError) as raised:
        replay_variant(log, probe_system(), NOISY, end_cycle=200, allow_truncated=True)
    with pytest.raises(WindowError) as replayed:
        replay(log, probe_system(), end_cycle=200, allow_truncated=True)

    assert str(raised.value) == str(replayed.value)
