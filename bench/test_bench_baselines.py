"""The baseline-size bench: the suite it re-baselines names the retuned perception, and
each pending file is weighed against its own log."""

from __future__ import annotations

from pathlib import Path

from beatlog_examples.dog import SUITE_DIR
from bench_baselines import retuned_suite, weigh


def test_every_spec_of_the_copy_names_the_retuned_perception(tmp_path: Path) -> None:
    suite = retuned_suite(tmp_path, 0.25)

    specs = sorted(suite.glob("*.dtc.toml"))
    assert [spec.name for spec in specs] == sorted(p.name for p in SUITE_DIR.glob("*.dtc.toml"))
    assert {
        line
        for spec in specs
        for line in spec.read_text(encoding="utf-8").splitlines()
        if line.startswith("perception")
    } == {'perception = "retuned_perception:perception"'}
    module = (suite / "retuned_perception.py").read_text(encoding="utf-8")
    assert module.count("\nSPEED_SMOOTHING = 0.25\n") == 1


def test_a_pending_baseline_is_weighed_against_its_log(tmp_path: Path) -> None:
    suite = retuned_suite(tmp_path, 0.1)
    for spec in suite.glob("*.dtc.toml"):
        if spec.name != "tip-over.dtc.toml":
            spec.unlink()

    (weight,) = weigh(suite, jobs=1)

    assert weight.name == "tip-over"
    assert weight.log == (SUITE_DIR / "tip-over.beatlog").stat().st_size
    assert weight.baseline == (suite / "tip-over.dtc.pending").stat().st_size
    assert weight.text >= weight.baseline
    assert (weight.pinned_cycles, weight.robot_states) == (983, 3076)
