"""Specs written as TOML text: a spec's data written back loads as it was."""

from __future__ import annotations

from pathlib import Path

from beatlog.replaying.perturbation import Perturbations
from beatlog.suite.spec import load_spec, read_spec_data, spec_from_data
from beatlog.suite.spec_writing import spec_text, spec_toml
from tests.specs import write_spec


def test_a_specs_data_written_as_toml_loads_back_the_same(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        "round-trip",
        "probe.beatlog",
        tags=["a b"],
        end_cycle=60,
        renames={"near": "close"},
        field_renames={"pose.x": "pose.px"},
        tolerance={"speed": 1e-9},
    )
    data = read_spec_data(path)
    again = tmp_path / "again.dtc.toml"
    again.write_text(spec_toml(data), encoding="utf-8")

    assert read_spec_data(again) == data
    assert spec_from_data(again, data) == load_spec(again)


def test_a_new_spec_declares_the_variants_it_is_given(tmp_path: Path) -> None:
    path = tmp_path / "walk.dtc.toml"
    path.write_text(
        spec_text(
            name="walk",
            purpose="Walks.",
            procedure=["Start it."],
            log="walk.beatlog",
            system="tests.conftest:probe_system",
            variants={"heartbeat_jitter": 0.002, "noise": {"battery": 0.5, "pose.x": 0.01}},
        ),
        encoding="utf-8",
    )

    spec = load_spec(path)

    assert spec.perturbations == Perturbations(
        heartbeat_jitter=0.002, noise={"battery": 0.5, "pose.x": 0.01}
    )
    assert spec.variant_count == 0
