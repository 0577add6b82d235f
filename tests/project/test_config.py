"""The project's configuration: renames and field migrations for every spec, and the
systems it vouches for."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import SpecError, SystemLoadError
from beatlog.project.config import ProjectConfig, VariantsConfig, project_config, vouched_system
from tests.factories import vouch

LOG = Path("walk.beatlog")


def test_the_configuration_is_read_from_the_nearest_pyproject(tmp_path: Path) -> None:
    vouch(tmp_path, "robot.nav:system", "robot.arm:system")
    inner = tmp_path / "suite" / "night"
    inner.mkdir(parents=True)

    assert project_config(inner) == ProjectConfig(
        renames={}, systems=["robot.nav:system", "robot.arm:system"]
    )


def test_a_project_without_pyproject_vouches_for_nothing(tmp_path: Path) -> None:
    with pytest.raises(SystemLoadError) as raised:
        vouched_system(LOG, "robot.nav:system", project=tmp_path)

    assert str(raised.value) == (
        "walk.beatlog: records the system 'robot.nav:system', which this project does not "
        "vouch for; name it (--system, or system = in the spec) or list it under "
        "[tool.beatlog] systems in a pyproject.toml"
    )


def test_a_listed_reference_is_the_one_used(tmp_path: Path) -> None:
    vouch(tmp_path, "robot.nav:system")

    assert vouched_system(LOG, "robot.nav:system", project=tmp_path) == "robot.nav:system"


@pytest.mark.parametrize(
    "recorded", ["tempfile:mkdtemp", "this:s", "os:getcwd", "robot.nav:system ", "robot.nav"]
)
def test_an_unlisted_reference_is_refused_naming_the_pyproject(
    tmp_path: Path, recorded: str
) -> None:
    pyproject = vouch(tmp_path, "robot.nav:system")

    with pytest.raises(SystemLoadError) as raised:
        vouched_system(LOG, recorded, project=tmp_path)

    assert str(raised.value) == (
        f"walk.beatlog: records the system {recorded!r}, which this project does not vouch "
        f"for; name it (--system, or system = in the spec) or list it under "
        f"[tool.beatlog] systems in {pyproject}"
    )


def test_a_log_that_records_no_system_says_so(tmp_path: Path) -> None:
    vouch(tmp_path, "")

    with pytest.raises(SystemLoadError) as raised:
        vouched_system(LOG, "", project=tmp_path)

    assert (
        str(raised.value) == "walk.beatlog: records no system; name one as module:factory "
        "(--system, or system = in the spec)"
    )


def test_a_long_recorded_reference_is_cut_in_the_message(tmp_path: Path) -> None:
    with pytest.raises(SystemLoadError) as raised:
        vouched_system(LOG, "x" * 10_000 + ":y", project=tmp_path)

    assert (
        str(raised.value)
        == f"walk.beatlog: records the system '{'x' * 80}…', which this project does not vouch "
        "for; name it (--system, or system = in the spec) or list it under [tool.beatlog] systems "
        "in a pyproject.toml"
    )
    assert len(str(raised.value)) < 300


def test_systems_that_are_not_a_list_of_strings_name_the_key(tmp_path: Path) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text('[tool.beatlog]\nsystems = "robot.nav:system"\n', encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == (
        f"{pyproject}: key 'tool.beatlog.systems': expected a list, got a string"
    )


def test_an_unknown_key_is_named_with_the_key_it_may_mean(tmp_path: Path) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text('[tool.beatlog]\nsystem = ["robot.nav:system"]\n', encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == (
        f"{pyproject}: unknown key 'tool.beatlog.system' (did you mean 'tool.beatlog.systems'?)"
    )


def test_field_renames_and_conversions_hold_dotted_paths_for_nested_fields(
    tmp_path: Path,
) -> None:
    (tmp_path / "pyproject.toml").write_text(
        "[tool.beatlog.field_renames]\n"
        'knee_mean = "knee_avg"\n'
        'pose.x = "pose.px"\n'
        '"arm.angle" = "arm.theta"\n'
        "[tool.beatlog.field_conversions]\n"
        'battery = "robot.compat:percent"\n',
        encoding="utf-8",
    )

    config = project_config(tmp_path)

    assert config.field_renames == {
        "knee_mean": "knee_avg",
        "pose.x": "pose.px",
        "arm.angle": "arm.theta",
    }
    assert config.field_conversions == {"battery": "robot.compat:percent"}


@pytest.mark.parametrize(
    ("table", "problem"),
    [
        (
            '[tool.beatlog.field_renames]\na = "c"\nb = "c"\n',
            "key 'tool.beatlog.field_renames': 'a' and 'b' are both renamed to 'c'",
        ),
        (
            '[tool.beatlog.field_conversions]\nbattery = "percent"\n',
            "key 'tool.beatlog.field_conversions.battery': expected module:function, got 'percent'",
        ),
    ],
)
def test_bad_field_migrations_name_the_pyproject_and_the_key(
    tmp_path: Path, table: str, problem: str
) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(table, encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == f"{pyproject}: {problem}"


def test_the_open_loop_limits_are_read_from_the_project(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        "[tool.beatlog]\nmax_open_loop_share = 0.5\nmax_open_loop_dtcs = 3\n", encoding="utf-8"
    )

    config = project_config(tmp_path)

    assert (config.max_open_loop_share, config.max_open_loop_dtcs) == (0.5, 3)


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("max_open_loop_share = 1.5", "max_open_loop_share': expected a number <= 1.0"),
        ('max_open_loop_share = "half"', "max_open_loop_share': expected a number, got a string"),
        ("max_open_loop_dtcs = -1", "max_open_loop_dtcs': expected an integer >= 0"),
        ("max_open_loop_dtcs = 2.5", "max_open_loop_dtcs': expected an integer, got a number"),
    ],
)
def test_bad_open_loop_limits_name_the_pyproject_and_the_key(
    tmp_path: Path, line: str, problem: str
) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(f"[tool.beatlog]\n{line}\n", encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == f"{pyproject}: key 'tool.beatlog.{problem}"


def test_the_invariants_of_every_spec_are_read_from_the_project(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[tool.beatlog]\ninvariants = ["robot.checks:never_fall", "robot.checks:Docks"]\n',
        encoding="utf-8",
    )

    assert project_config(tmp_path).invariants == ["robot.checks:never_fall", "robot.checks:Docks"]


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ('["robot.checks"]', "invariants[0]': expected module:attribute, got 'robot.checks'"),
        ('"robot.checks:never_fall"', "invariants': expected a list, got a string"),
    ],
)
def test_bad_invariants_name_the_pyproject_and_the_key(
    tmp_path: Path, value: str, problem: str
) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(f"[tool.beatlog]\ninvariants = {value}\n", encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == f"{pyproject}: key 'tool.beatlog.{problem}"


def test_the_variants_of_every_spec_are_read_from_the_project(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        "[tool.beatlog.variants]\ncount = 8\nnoise = { battery = 0.05, pose.x = 0.01 }\n",
        encoding="utf-8",
    )

    assert project_config(tmp_path).variants == VariantsConfig(
        count=8, noise={"battery": 0.05, "pose.x": 0.01}
    )


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("count = -1", "variants.count': expected an integer >= 0"),
        ("delay_samples = 2.0", "variants.delay_samples': expected a number <= 1.0"),
        ("draw = true", "variants': object contains unknown field `draw`"),
    ],
)
def test_bad_variants_name_the_pyproject_and_the_key(
    tmp_path: Path, line: str, problem: str
) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text(f"[tool.beatlog.variants]\n{line}\n", encoding="utf-8")

    with pytest.raises(SpecError) as raised:
        project_config(tmp_path)

    assert str(raised.value) == f"{pyproject}: key 'tool.beatlog.{problem}"
