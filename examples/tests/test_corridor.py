"""The corridor example: a ROS 2 bag of a sonar that imports into a passing DTC."""

from __future__ import annotations

from pathlib import Path

import pytest

import beatlog
from beatlog.adapters.rosbag import import_bag
from beatlog_examples.corridor import main, perception, system


def test_the_bag_imports_into_a_session_the_system_brakes_in(tmp_path: Path) -> None:
    main([str(tmp_path / "corridor")])

    imported = import_bag(
        tmp_path / "corridor",
        tmp_path / "corridor.beatlog",
        system=system(),
        perception=perception(),
    )
    result = beatlog.replay(imported.log, system(), perception=perception())

    assert (result.ok, result.divergence, result.counts) == (
        True,
        None,
        {"cycles": 67, "state_changes": 2, "outputs": 17, "draws": 0, "samples": 200},
    )
    assert imported.topics == ("/sonar",)
    assert imported.samples == 200


def test_an_existing_folder_is_never_overwritten(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "corridor").mkdir()

    with pytest.raises(SystemExit) as exited:
        main([str(tmp_path / "corridor")])

    assert exited.value.code == 2
    assert (
        capsys.readouterr().err == f"{tmp_path / 'corridor'}: exists already; give a new folder\n"
    )
