"""DTC specs: one TOML file per test case, validated with errors that name file and key."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import SpecError
from beatlog.replay.compare import Comparison
from beatlog.replay.fit.migration import StateMigration
from beatlog.replay.perturbation import Perturbations
from beatlog.suite.spec import load_spec, read_spec_data, spec_from_data, spec_text, spec_toml
from tests.conftest import RecordFn
from tests.specs import PROBE, write_spec

# load_spec


def test_a_valid_spec_loads_with_its_log_resolved_against_the_spec_folder(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    path = write_spec(
        tmp_path / "specs" / "obstacles",
        "avoid-pole",
        log,
        tags=["obstacles", "smoke"],
        allow_truncated=True,
        allow_empty=True,
    )

    spec = load_spec(path)

    assert spec.path == path
    assert spec.name == "avoid-pole"
    assert spec.purpose == "The probe replays avoid-pole as recorded."
    assert spec.procedure == ("Drive the probe toward the pole and back, twice.",)
    assert spec.log == path.parent / ".." / ".." / log.name
    assert spec.log.resolve() == log.resolve()
    assert spec.system == PROBE
    assert spec.tags == ("obstacles", "smoke")
    assert spec.allow_truncated is True
    assert spec.allow_empty is True


def test_a_log_that_is_a_url_is_kept_as_one_and_named_by_it(tmp_path: Path) -> None:
    url = "https://host/suite/walk.beatlog"

    spec = load_spec(write_spec(tmp_path, "walk", url))

    assert spec.log_url == spec.log_name == url
    assert spec.log == Path("walk.beatlog")
    assert spec.origin == str(tmp_path / "walk.dtc.toml")


def test_a_local_log_has_no_url_and_is_named_by_its_path(
    tmp_path: Path, record_probe: RecordFn
) -> None:
    spec = load_spec(write_spec(tmp_path, "walk", record_probe(30)))

    assert spec.log_url is None
    assert spec.log_name == str(tmp_path / "probe.beatlog")
    with spec.readable_log() as log:
        assert log == spec.log


def test_tags_and_allowances_are_optional(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, "plain", "probe.beatlog"))

    assert spec.log == tmp_path / "probe.beatlog"
    assert spec.tags == ()
    assert spec.allow_truncated is False
    assert spec.allow_empty is False


def assert_spec_error(path: Path, problem: str) -> None:
    """Loading ``path`` must raise a SpecError of one line: the path, then ``problem``."""
    with pytest.raises(SpecError) as raised:
        load_spec(path)
    assert str(raised.value) == f"{path}: {problem}"


def test_without_a_system_a_spec_replays_against_the_one_its_log_records(
    tmp_path: Path,
) -> None:
    spec = load_spec(write_spec(tmp_path, "plain", "probe.beatlog", system=None))

    assert spec.system is None


def test_a_missing_spec_file_is_a_spec_error(tmp_path: Path) -> None:
    assert_spec_error(tmp_path / "gone.dtc.toml", "no such file")


def test_invalid_toml_is_a_spec_error_with_the_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.dtc.toml"
    path.write_text('name = "unterminated\n', encoding="utf-8")

    assert_spec_error(path, "not valid TOML: Illegal character '\\n' (at line 1, column 21)")


@pytest.mark.parametrize("key", ["name", "purpose", "procedure", "log"])
def test_every_required_key_must_be_there(tmp_path: Path, key: str) -> None:
    path = write_spec(tmp_path, "incomplete", "probe.beatlog", **{key: None})

    assert_spec_error(path, f"missing key {key!r}")


@pytest.mark.parametrize(
    ("key", "value", "where", "problem"),
    [
        (
            "procedure",
            "Drive toward the pole.",
            "key 'procedure'",
            "expected a list, got a string",
        ),
        (
            "procedure",
            ["Drive toward the pole.", 30],
            "key 'procedure[1]'",
            "expected a string, got an integer",
        ),
        ("tags", "obstacles", "key 'tags'", "expected a list, got a string"),
        ("allow_truncated", "yes", "key 'allow_truncated'", "expected true or false, got a string"),
        ("allow_empty", 1, "key 'allow_empty'", "expected true or false, got an integer"),
    ],
    ids=[
        "procedure-as-string",
        "procedure-item-not-string",
        "tags-not-list",
        "bool-as-string",
        "bool-as-number",
    ],
)
def test_a_wrong_type_names_the_key(
    tmp_path: Path, key: str, value: object, where: str, problem: str
) -> None:
    path = write_spec(tmp_path, "typo", "probe.beatlog", **{key: value})

    assert_spec_error(path, f"{where}: {problem}")


def test_an_unknown_key_is_rejected_so_typos_do_not_pass_silently(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "typo", "probe.beatlog", allow_truncate=True)

    assert_spec_error(path, "unknown key 'allow_truncate' (did you mean 'allow_truncated'?)")


@pytest.mark.parametrize(
    ("typo", "meant"),
    [("tag", "tags"), ("allow_truncate", "allow_truncated"), ("perceptoin", "perception")],
)
def test_an_unknown_key_names_the_key_it_may_mean(tmp_path: Path, typo: str, meant: str) -> None:
    path = write_spec(tmp_path, "typo", "probe.beatlog", **{typo: ["x"]})

    with pytest.raises(SpecError) as raised:
        load_spec(path)

    assert str(raised.value) == f"{path}: unknown key {typo!r} (did you mean {meant!r}?)"


def test_every_unknown_and_missing_key_is_named_at_once(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path, "sparse", "probe.beatlog", purpose=None, procedure=None, colour="red"
    )

    with pytest.raises(SpecError) as raised:
        load_spec(path)

    assert str(raised.value) == (
        f"{path}: unknown key 'colour'; missing keys 'purpose', 'procedure'"
    )


def test_an_empty_name_is_rejected(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "blank", "probe.beatlog", name="  ")

    assert_spec_error(path, "key 'name': must not be empty")


def test_a_window_of_cycles_loads_into_the_spec(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, "window", "probe.beatlog", start_cycle=40, end_cycle=60))

    assert (spec.start_cycle, spec.end_cycle) == (40, 60)
    assert not spec.fresh_start


def test_a_window_may_start_fresh(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "fresh", "probe.beatlog", start_cycle=40, fresh_start=True)

    spec = load_spec(path)

    assert (spec.start_cycle, spec.fresh_start) == (40, True)


def test_without_a_window_a_spec_judges_every_cycle(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, "whole", "probe.beatlog"))

    assert (spec.start_cycle, spec.end_cycle) == (0, None)


@pytest.mark.parametrize(
    ("window", "problem"),
    [
        ({"start_cycle": -1}, "key 'start_cycle': expected an integer >= 0"),
        ({"end_cycle": -3}, "key 'end_cycle': expected an integer >= 0"),
        ({"start_cycle": 61, "end_cycle": 60}, "key 'start_cycle': 61 is after end_cycle 60"),
    ],
)
def test_a_window_that_holds_no_cycle_is_rejected(
    tmp_path: Path, window: dict[str, int], problem: str
) -> None:
    path = write_spec(tmp_path, "window", "probe.beatlog", **window)

    assert_spec_error(path, problem)


def test_a_system_without_a_colon_is_rejected(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "no-factory", "probe.beatlog", system="tests.conftest")

    assert_spec_error(path, "key 'system': expected module:factory, got 'tests.conftest'")


def test_comparison_allowances_load_into_the_spec(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        "lenient",
        "probe.beatlog",
        renames={"near": "close"},
        ignore_behaviors=["dice"],
        ignore_fields=["debug_*"],
        tolerance={"speed": 1e-9},
        robot_state_tolerance={"distance": 1e-6},
    )

    comparison = load_spec(path).comparison

    assert comparison.renames == {"near": "close"}
    assert comparison.ignore_behaviors == frozenset({"dice"})
    assert comparison.ignore_fields == ("debug_*",)
    assert comparison.tolerance == {"speed": 1e-9}
    assert comparison.state_tolerance == {"distance": 1e-6}


def test_by_default_a_spec_compares_exactly(tmp_path: Path) -> None:
    assert load_spec(write_spec(tmp_path, "exact", "probe.beatlog")).comparison == Comparison()


@pytest.mark.parametrize(
    ("extra", "problem"),
    [
        ({"tolerance": {"speed": -1.0}},
         "key 'tolerance.speed': expected a finite number >= 0, got -1.0"),
        ({"tolerance": {"speed": "tiny"}}, "key 'tolerance.*': expected a number, got a string"),
        ({"robot_state_tolerance": {"distance": -1e-3}},
         "key 'robot_state_tolerance.distance': expected a finite number >= 0, got -0.001"),
        ({"robot_state_tolerance": {"distance": float("nan")}},
         "key 'robot_state_tolerance.distance': expected a finite number >= 0, got nan"),
        ({"robot_state_tolerance": {"distance": float("inf")}},
         "key 'robot_state_tolerance.distance': expected a finite number >= 0, got inf"),
        ({"robot_state_tolerance": {"distance": "tiny"}},
         "key 'robot_state_tolerance.*': expected a number, got a string"),
        ({"renames": {"a": "c", "b": "c"}}, "key 'renames': 'a' and 'b' are both renamed to 'c'"),
        ({"renames": {"a": 1}}, "key 'renames.*': expected a string, got an integer"),
        ({"ignore_behaviors": "dice"}, "key 'ignore_behaviors': expected a list, got a string"),
        ({"field_renames": {"a": "c", "b": "c"}},
         "key 'field_renames': 'a' and 'b' are both renamed to 'c'"),
        ({"field_renames": {"pose": {"x": 1}}},
         "key 'field_renames.*': expected a string, got an integer"),
        ({"field_conversions": {"battery": "percent"}},
         "key 'field_conversions.battery': expected module:function, got 'percent'"),
    ],
    ids=["negative-tolerance", "tolerance-not-number", "negative-state-tolerance",
         "nan-state-tolerance", "infinite-state-tolerance", "state-tolerance-not-number",
         "renames-not-one-to-one",
         "rename-not-string", "ignore-not-list", "field-renames-not-one-to-one",
         "field-rename-not-string", "conversion-not-a-reference"],
)  # fmt: skip
def test_bad_allowances_name_the_key(
    tmp_path: Path, extra: dict[str, object], problem: str
) -> None:
    assert_spec_error(write_spec(tmp_path, "bad", "probe.beatlog", **extra), problem)


def test_project_renames_come_from_pyproject_and_the_spec_adds_to_them(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "robot"\n\n[tool.beatlog.renames]\nnear = "close"\nold = "new"\n',
        encoding="utf-8",
    )
    path = write_spec(tmp_path / "specs", "renamed", "probe.beatlog", renames={"old": "newer"})

    assert load_spec(path).comparison.renames == {"near": "close", "old": "newer"}


def test_robot_state_fields_renamed_or_retyped_load_into_the_specs_migration(
    tmp_path: Path,
) -> None:
    path = write_spec(
        tmp_path,
        "migrated",
        "probe.beatlog",
        field_renames={"distance": "range", "pose": {"x": "pose.px"}},
        field_conversions={"battery": "tests.systems:centimetres"},
    )

    assert load_spec(path).migration == StateMigration(
        {"distance": "range", "pose.x": "pose.px"}, {"battery": "tests.systems:centimetres"}
    )
    assert not load_spec(write_spec(tmp_path, "as-recorded", "probe.beatlog")).migration


def test_a_dotted_key_names_a_field_inside_a_struct_quoted_or_not(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "nested", "probe.beatlog")
    path.write_text(
        path.read_text(encoding="utf-8")
        + 'field_renames = { pose.x = "pose.px", "arm.angle" = "arm.theta" }\n',
        encoding="utf-8",
    )

    assert load_spec(path).migration.renames == {"pose.x": "pose.px", "arm.angle": "arm.theta"}


def test_project_field_migrations_come_from_pyproject_and_the_spec_adds_to_them(
    tmp_path: Path,
) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "robot"\n\n[tool.beatlog.field_renames]\ndistance = "range"\n'
        'pose.x = "pose.px"\n\n[tool.beatlog.field_conversions]\nbattery = "robot.compat:pct"\n',
        encoding="utf-8",
    )
    path = write_spec(
        tmp_path / "specs", "migrated", "probe.beatlog", field_renames={"pose.x": "pose.x2"}
    )

    assert load_spec(path).migration == StateMigration(
        {"distance": "range", "pose.x": "pose.x2"}, {"battery": "robot.compat:pct"}
    )


def test_bad_project_renames_name_the_pyproject(tmp_path: Path) -> None:
    pyproject = tmp_path / "pyproject.toml"
    pyproject.write_text("[tool.beatlog]\nrenames = 3\n", encoding="utf-8")
    path = write_spec(tmp_path / "specs", "renamed", "probe.beatlog")

    with pytest.raises(SpecError) as raised:
        load_spec(path)
    assert str(raised.value) == (
        f"{pyproject}: key 'tool.beatlog.renames': expected a table, got an integer"
    )


def test_project_invariants_come_first_and_the_spec_adds_to_them(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[tool.beatlog]\ninvariants = ["robot.checks:a", "robot.checks:b"]\n', encoding="utf-8"
    )
    path = write_spec(
        tmp_path / "specs",
        "checked",
        "probe.beatlog",
        invariants=["robot.checks:c", "robot.checks:a"],
    )

    assert load_spec(path).invariants == ("robot.checks:a", "robot.checks:b", "robot.checks:c")


def test_by_default_a_spec_checks_no_invariant(tmp_path: Path) -> None:
    assert load_spec(write_spec(tmp_path, "plain", "probe.beatlog")).invariants == ()


def test_an_invariant_without_a_colon_is_rejected_naming_the_spec(tmp_path: Path) -> None:
    path = write_spec(tmp_path, "checked", "probe.beatlog", invariants=["robot.checks"])

    with pytest.raises(SpecError) as raised:
        load_spec(path)
    assert str(raised.value) == (
        f"{path}: key 'invariants[0]': expected module:attribute, got 'robot.checks'"
    )


def test_a_written_spec_loads_back_as_written(tmp_path: Path) -> None:
    text = spec_text(
        name='tip "over"\x7f',
        purpose="Tipped to 60°.",
        procedure=["Put it down.", "Tip it\tover."],
        log="tip-over.beatlog",
        system="myrobot:system",
        tags=["touch", "falls"],
        perception="myrobot:perception",
        invariants=["myrobot.checks:upright", "myrobot.checks:Docks"],
    )
    path = tmp_path / "tip.dtc.toml"
    path.write_text(text, encoding="utf-8")

    spec = load_spec(path)

    assert (spec.name, spec.purpose) == ('tip "over"\x7f', "Tipped to 60°.")
    assert list(spec.procedure) == ["Put it down.", "Tip it\tover."]
    assert (spec.log, spec.system, spec.perception) == (
        tmp_path / "tip-over.beatlog",
        "myrobot:system",
        "myrobot:perception",
    )
    assert list(spec.tags) == ["touch", "falls"]
    assert spec.invariants == ("myrobot.checks:upright", "myrobot.checks:Docks")


def test_a_spec_declares_its_variants_in_a_table(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        "varied",
        "probe.beatlog",
        variants={"count": 8, "heartbeat_jitter": 0.002, "noise": {"distance": 0.05}},
    )

    spec = load_spec(path)

    assert spec.perturbations == Perturbations(heartbeat_jitter=0.002, noise={"distance": 0.05})
    assert spec.variant_count == 8
    assert spec.variant is None


def test_a_spec_without_variants_declares_none(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, "plain", "probe.beatlog"))

    assert spec.perturbations is None
    assert spec.variant_count == 0


def test_the_projects_variants_apply_to_every_spec_and_the_spec_comes_on_top(
    tmp_path: Path,
) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "robot"\n\n[tool.beatlog.variants]\ncount = 4\ndraws = false\n'
        "noise = { distance = 0.1, pose.x = 0.01 }\n",
        encoding="utf-8",
    )
    plain = write_spec(tmp_path / "specs", "plain", "probe.beatlog")
    own = write_spec(
        tmp_path / "specs", "own", "probe.beatlog", variants={"noise": {"distance": 0.2}}
    )

    assert load_spec(plain).perturbations == Perturbations(
        draws=False, noise={"distance": 0.1, "pose.x": 0.01}
    )
    assert load_spec(own).perturbations == Perturbations(
        draws=False, noise={"distance": 0.2, "pose.x": 0.01}
    )
    assert load_spec(own).variant_count == 4


def test_a_variants_own_spec_ignores_the_projects_variants(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text(
        '[project]\nname = "robot"\n\n[tool.beatlog.variants]\nnoise = { distance = 0.1 }\n',
        encoding="utf-8",
    )
    bare = write_spec(tmp_path / "specs", "bare", "probe.beatlog", variant=3)
    own = write_spec(
        tmp_path / "specs", "own", "probe.beatlog", variant=2, variants={"draws": False}
    )

    assert load_spec(bare).perturbations == Perturbations()
    assert load_spec(bare).variant == 3
    assert load_spec(own).perturbations == Perturbations(draws=False)


@pytest.mark.parametrize(
    ("extra", "problem"),
    [
        ({"variants": {"noise": {"distance": -0.1}}},
         "key 'variants.noise.distance': expected a finite number >= 0, got -0.1"),
        ({"variants": {"noise": {"distance": float("nan")}}},
         "key 'variants.noise.distance': expected a finite number >= 0, got nan"),
        ({"variants": {"heartbeat_jitter": float("inf")}},
         "key 'variants.heartbeat_jitter': expected a finite number >= 0, got inf"),
        ({"variants": {"heartbeat_jitter": -0.001}},
         "key 'variants.heartbeat_jitter': expected a number >= 0.0"),
        ({"variants": {"drop_samples": 1.5}},
         "key 'variants.drop_samples': expected a number <= 1.0"),
        ({"variants": {"count": -1}}, "key 'variants.count': expected an integer >= 0"),
        ({"variants": {"jitter": 0.1}}, "key 'variants': object contains unknown field `jitter`"),
        ({"variant": 0}, "key 'variant': expected an integer >= 1"),
    ],
    ids=["negative-noise", "nan-noise", "infinite-jitter", "negative-jitter", "share-above-one",
         "negative-count", "unknown-key", "variant-zero"],
)  # fmt: skip
def test_bad_variants_name_the_key(tmp_path: Path, extra: dict[str, object], problem: str) -> None:
    assert_spec_error(write_spec(tmp_path, "bad", "probe.beatlog", **extra), problem)


# spec_toml and spec_text


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
