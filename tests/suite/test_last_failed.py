"""The DTCs that failed last time, for ``--lf``: remembered by id, forgotten once they
pass, kept while not run; a damaged memory is ignored with a warning, never a crash."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.suite.last_failed import last_failed_path, remember_failed, rerun_failed
from beatlog.suite.parallel import run_suite
from beatlog.suite.spec import DtcSpec, load_spec
from tests.conftest import RecordFn
from tests.specs import CHANGED, write_spec


@pytest.fixture
def suite(tmp_path: Path, record_probe: RecordFn) -> list[DtcSpec]:
    """Two DTCs of one log: ``approach`` passes, ``changed`` fails."""
    log = record_probe(60)
    folder = tmp_path / "specs"
    return [
        load_spec(write_spec(folder, "approach", log)),
        load_spec(write_spec(folder, "changed", log, CHANGED)),
    ]


def test_the_failures_are_remembered_and_rerun(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)

    assert remember_failed(run_suite(suite), path) is None

    assert rerun_failed(suite, path) == (
        [suite[1]],
        "--lf: rerunning the 1 DTC that failed last time",
    )


def test_nothing_is_written_while_nothing_failed(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)

    assert remember_failed(run_suite(suite[:1]), path) is None

    assert not path.parent.exists()


def test_a_damaged_memory_is_ignored_with_a_warning(suite: list[DtcSpec]) -> None:
    path = last_failed_path(suite[0].path.parent)
    path.parent.mkdir()
    path.write_text("{not json", encoding="utf-8")

    chosen, said = rerun_failed(suite, path)

    assert chosen == suite
    assert said.startswith(
        "--lf: no DTC selected failed last time; running all 2 "
        f"({path}: not a beatlog memory of failed DTCs ("
    )
    assert said.endswith("; ignored, and replaced by what this run saw)")
    assert remember_failed(run_suite(suite), path) is not None
    assert rerun_failed(suite, path)[0] == [suite[1]]
