"""Re-recording the suite: specs written for each scenario load as DTC specs, and are the
committed ones."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.replay.perturbation import Perturbations
from beatlog.suite.spec import load_spec
from beatlog_examples.dog import SUITE_DIR, invariants
from beatlog_examples.dog.record_suite import main, spec_text
from beatlog_examples.dog.scenarios import SUITE, Scenario, scenario
from beatlog_examples.dog.variants import VARIANTS


@pytest.mark.parametrize("case", SUITE, ids=lambda case: case.name)
def test_every_scenario_gives_a_valid_spec(case: object, tmp_path: Path) -> None:
    assert case in SUITE
    chosen = scenario(getattr(case, "name", ""))
    path = tmp_path / f"{chosen.name}.dtc.toml"
    path.write_text(spec_text(chosen, f"{chosen.name}.beatlog"), encoding="utf-8")
    spec = load_spec(path)
    assert spec.name == chosen.name
    assert spec.purpose == chosen.purpose
    assert list(spec.procedure) == chosen.procedure()
    assert spec.log == tmp_path / f"{chosen.name}.beatlog"
    assert spec.system == "beatlog_examples.dog:system"
    assert spec.tags == chosen.tags
    assert spec.invariants == tuple(invariants.ALL)
    assert spec.perturbations == Perturbations(**VARIANTS)
    assert spec.variant_count == 0


@pytest.mark.parametrize("case", SUITE, ids=lambda case: case.name)
def test_every_committed_spec_is_the_one_recording_writes(case: Scenario) -> None:
    committed = SUITE_DIR / f"{case.name}.dtc.toml"
    assert committed.read_text(encoding="utf-8") == spec_text(case, f"{case.name}.beatlog")


def test_an_unknown_case_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path), "--only", "fetch"])
    assert exit_info.value.code == 2
    names = ", ".join(sorted(case.name for case in SUITE))
    assert capsys.readouterr().err.splitlines()[-1] == (
        "python -m beatlog_examples.dog.record_suite: error: "
        f"no scenario named 'fetch'; choose from {names}"
    )
    assert not list(tmp_path.iterdir())
