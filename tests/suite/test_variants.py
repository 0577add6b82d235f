"""Variants in a suite: each DTC that declares variants is followed by them, each a DTC
of its own, and a variant that fails is written as a spec that fails again, bit for bit."""

from __future__ import annotations

from pathlib import Path

from beatlog.replay.verdict import DivergenceKind
from beatlog.suite.discovery import discover_specs
from beatlog.suite.parallel import run_suite
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
from beatlog.suite.spec import DtcSpec, load_spec
from beatlog.suite.variants import with_variants, write_variant_spec
from tests.conftest import RecordFn
from tests.specs import PROBE, write_spec

FUSSY = "tests.systems:fussy_system"
"""The probe with a bug no recording reaches: it raises on a negative distance."""
NOISY = {"noise": {"distance": 0.05}, "heartbeat_jitter": 0.001}
STARTED = 1_700_000_000_000_000_000
"""When the logs whose variants must fail were recorded: it keys their variants."""


def test_each_dtc_that_declares_variants_is_followed_by_them(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100)
    varied = load_spec(write_spec(tmp_path, "varied", log, variants={"count": 2}))
    plain = load_spec(write_spec(tmp_path, "plain", log))

    run = with_variants([varied, plain])

    assert [spec.id for spec in run] == [
        varied.id,
        f"{varied.id}[variant-1]",
        f"{varied.id}[variant-2]",
        plain.id,
    ]
    assert [spec.name for spec in run] == [
        "varied",
        "varied[variant-1]",
        "varied[variant-2]",
        "plain",
    ]
    assert [spec.variant for spec in run] == [None, 1, 2, None]
    assert run[1].own_spec == tmp_path / "varied.variant-1.dtc.toml"


def test_a_count_given_takes_the_place_of_each_dtcs_own(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    varied = load_spec(write_spec(tmp_path, "varied", record_probe(100), variants={"count": 2}))

    assert [spec.variant for spec in with_variants([varied], 3)] == [None, 1, 2, 3]
    assert with_variants([varied], 0) == [varied]


def failing_variant(spec: DtcSpec) -> tuple[DtcSpec, SpecOutcome]:
    """The first of variants 1..8 of ``spec`` that fails, and its outcome."""
    for variant in with_variants([spec], 8)[1:]:
        outcome = run_spec(variant)
        if outcome.verdict is Verdict.FAILED:
            return variant, outcome
    raise AssertionError("no variant failed")


def test_a_failing_variant_is_written_as_a_spec_that_fails_again_bit_for_bit(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=STARTED)
    spec = load_spec(write_spec(tmp_path / "dtc", "dock", log, FUSSY, variants=NOISY))
    assert run_spec(spec).verdict is Verdict.PASSED  # the recording never reaches the bug
    variant, outcome = failing_variant(spec)

    written = write_variant_spec(variant)
    again = run_spec(load_spec(written))

    assert written == tmp_path / "dtc" / f"dock.variant-{variant.variant}.dtc.toml"
    assert outcome.result is not None
    assert again.result is not None
    assert outcome.result.reproduce == f"beatlog test {written}"
    assert again.result.reproduce == f"beatlog test {written}"
    assert again.verdict is Verdict.FAILED
    assert again.result.divergence == outcome.result.divergence
    assert (again.result.cycles, again.result.checked, again.result.robot_time_ns) == (
        outcome.result.cycles,
        outcome.result.checked,
        outcome.result.robot_time_ns,
    )


def test_a_written_variant_names_the_log_and_every_perturbation_and_keeps_them(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100)
    spec = load_spec(write_spec(tmp_path / "dtc", "dock", log, FUSSY, variants=NOISY))
    variant = with_variants([spec], 3)[3]

    written = load_spec(write_variant_spec(variant))
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "robot"\n\n[tool.beatlog.variants]\nnoise = { distance = 0.5 }\n',
        encoding="utf-8",
    )

    assert written.name == "dock-variant-3"
    assert written.log.resolve() == log.resolve()
    assert written.system == FUSSY
    assert written.variant == 3
    assert written.perturbations == spec.perturbations
    assert load_spec(written.path).perturbations == spec.perturbations  # project changed
    assert 'log = "../probe.beatlog"' in written.path.read_text(encoding="utf-8")


def test_a_written_variant_of_a_window_keeps_the_window(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100)
    window = {"start_cycle": 20, "end_cycle": 60, "fresh_start": True}
    spec = load_spec(write_spec(tmp_path, "dock", log, FUSSY, variants=NOISY, **window))

    written = load_spec(write_variant_spec(with_variants([spec], 1)[1]))

    assert (written.start_cycle, written.end_cycle, written.fresh_start) == (20, 60, True)


def test_a_written_variant_is_found_as_a_dtc_of_its_own_with_no_variants(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100)
    spec = load_spec(write_spec(tmp_path, "dock", log, FUSSY, variants={**NOISY, "count": 4}))
    write_variant_spec(with_variants([spec], 2)[2])

    found = discover_specs([tmp_path])

    assert [dtc.name for dtc in with_variants(found)] == [
        "dock",
        *(f"dock[variant-{n}]" for n in range(1, 5)),
        "dock-variant-2",
    ]


def test_unchanged_code_passes_every_variant(tmp_path: Path, record_probe: RecordFn) -> None:
    log = record_probe(100)
    spec = load_spec(write_spec(tmp_path, "dock", log, PROBE, variants=NOISY))

    outcomes = run_suite(with_variants([spec], 8))

    assert [outcome.verdict for outcome in outcomes] == [Verdict.PASSED] * 9
    assert [outcome.spec.variant for outcome in outcomes] == [None, *range(1, 9)]


def test_a_variant_that_breaks_an_invariant_is_written_with_it_and_fails_again(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(100, start_time_ns=STARTED)
    invariants = ["tests.systems:never_negative"]
    spec = load_spec(
        write_spec(tmp_path, "dock", log, PROBE, variants=NOISY, invariants=invariants)
    )
    assert run_spec(spec).verdict is Verdict.PASSED
    variant, outcome = failing_variant(spec)

    written = load_spec(write_variant_spec(variant))
    again = run_spec(written)

    assert written.invariants == ("tests.systems:never_negative",)
    assert outcome.result is not None
    assert again.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.divergence.kind is DivergenceKind.INVARIANT
    assert again.result.divergence == outcome.result.divergence
