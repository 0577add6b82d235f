"""Variants: a recording replayed with deterministic perturbations, judged by the
behaviors not raising and by the invariants, never by the recording."""

from __future__ import annotations

from pathlib import Path

from beatlog import replay
from beatlog.replaying.perturbation import Perturbations, Variant
from beatlog.replaying.variant import replay_variant
from beatlog.replaying.verdict import DivergenceKind
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
