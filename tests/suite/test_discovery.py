"""Finding DTC specs: every spec under the folders given, loaded once, with ids from the
rootdir pytest would take; and the specs that ``-k`` and tags select, as pytest would."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import OptionError, SpecError
from beatlog.suite.discovery import (
    KeywordExpression,
    discover_specs,
    distinguished,
    select_specs,
)
from beatlog.suite.spec import DtcSpec, load_spec
from tests.conftest import RecordFn
from tests.specs import PROBE, write_spec

# discover_specs


def test_discovery_finds_specs_in_folders_recursively_sorted_by_path(tmp_path: Path) -> None:
    specs = tmp_path / "specs"
    write_spec(specs / "b", "zeta", "z.beatlog")
    write_spec(specs / "a" / "deep", "beta", "b.beatlog")
    write_spec(specs, "alpha", "a.beatlog")
    write_spec(specs / ".venv" / "lib", "vendored", "v.beatlog")  # hidden folders are skipped
    (specs / "notes.toml").write_text('name = "not a spec"\n', encoding="utf-8")
    (specs / "dir.dtc.toml").mkdir()  # a folder that merely looks like a spec

    found = discover_specs([specs])

    assert [spec.path.relative_to(specs).as_posix() for spec in found] == [
        "a/deep/beta.dtc.toml",
        "alpha.dtc.toml",
        "b/zeta.dtc.toml",
    ]
    assert [spec.name for spec in found] == ["beta", "alpha", "zeta"]


def test_discovery_accepts_a_spec_file_directly(tmp_path: Path) -> None:
    wanted = write_spec(tmp_path, "wanted", "w.beatlog")
    write_spec(tmp_path, "other", "o.beatlog")

    assert [spec.name for spec in discover_specs([wanted])] == ["wanted"]


def test_a_spec_given_twice_runs_once(tmp_path: Path) -> None:
    path = write_spec(tmp_path / "specs", "once", "o.beatlog")
    elsewhere = tmp_path / "specs" / ".." / "specs" / "once.dtc.toml"

    found = discover_specs([tmp_path / "specs", path, elsewhere])

    assert [spec.path for spec in found] == [path]


def test_a_missing_path_is_a_spec_error(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="no such file or folder") as raised:
        discover_specs([tmp_path / "nowhere"])

    assert raised.value.path == tmp_path / "nowhere"


def test_a_file_that_is_not_a_spec_is_a_spec_error(tmp_path: Path, record_probe: RecordFn) -> None:
    log = record_probe(10)

    with pytest.raises(SpecError, match=r"not a DTC spec \(expected a \*\.dtc\.toml file\)"):
        discover_specs([log])


def test_two_robots_may_each_have_a_dtc_of_one_name_told_apart_by_their_ids(
    tmp_path: Path,
) -> None:
    write_spec(tmp_path / "rover" / "dtc", "avoid-pole", "a.beatlog")
    write_spec(tmp_path / "dog" / "dtc", "avoid-pole", "b.beatlog")
    write_spec(tmp_path / "dog" / "dtc", "sit", "c.beatlog")

    specs = discover_specs([tmp_path])

    assert [spec.id for spec in specs] == [
        "dog/dtc/avoid-pole.dtc.toml::avoid-pole",
        "dog/dtc/sit.dtc.toml::sit",
        "rover/dtc/avoid-pole.dtc.toml::avoid-pole",
    ]
    assert [spec.label for spec in specs] == ["avoid-pole", "sit", "avoid-pole"]
    assert [spec.label for spec in distinguished(specs)] == [
        "dog/dtc/avoid-pole.dtc.toml::avoid-pole",
        "sit",
        "rover/dtc/avoid-pole.dtc.toml::avoid-pole",
    ]
    assert [spec.label for spec in distinguished(specs[:2])] == ["avoid-pole", "sit"]


def test_ids_start_from_the_rootdir_pytest_would_take(tmp_path: Path) -> None:
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "robots"\n')
    spec = write_spec(tmp_path / "rover" / "dtc", "avoid-pole", "a.beatlog")

    assert load_spec(spec).id == "rover/dtc/avoid-pole.dtc.toml::avoid-pole"
    assert discover_specs([spec.parent])[0].id == "rover/dtc/avoid-pole.dtc.toml::avoid-pole"
    assert load_spec(spec, rootdir=spec.parent).id == "avoid-pole.dtc.toml::avoid-pole"
    outside = load_spec(spec, rootdir=tmp_path / "dog")
    assert outside.id == "../rover/dtc/avoid-pole.dtc.toml::avoid-pole"


def test_a_bad_spec_stops_discovery(tmp_path: Path) -> None:
    write_spec(tmp_path, "good", "g.beatlog")
    bad = write_spec(tmp_path, "bad", "b.beatlog", log=None)

    with pytest.raises(SpecError, match="missing key 'log'") as raised:
        discover_specs([tmp_path])

    assert raised.value.path == bad


# select_specs


def spec(name: str, *tags: str) -> DtcSpec:
    return DtcSpec(
        path=Path(f"{name}.dtc.toml"),
        name=name,
        purpose="",
        procedure=(),
        log=Path("x.beatlog"),
        system=PROBE,
        tags=tags,
    )


SUITE = [
    spec("avoid-pole", "obstacles", "smoke"),
    spec("avoid-wall", "obstacles"),
    spec("dock", "smoke"),
    spec("dock-at-night", "night"),
]


def names(specs: list[DtcSpec]) -> list[str]:
    return [spec.name for spec in specs]


def test_selection_without_a_pattern_or_tags_keeps_every_spec_in_order() -> None:
    assert names(select_specs(SUITE)) == names(SUITE)


def test_a_plain_pattern_selects_by_substring() -> None:
    assert names(select_specs(SUITE, pattern="avoid")) == ["avoid-pole", "avoid-wall"]
    assert names(select_specs(SUITE, pattern="dock")) == ["dock", "dock-at-night"]


def test_a_pattern_is_an_expression_over_names_and_tags_as_pytest_reads_it() -> None:
    assert names(select_specs(SUITE, pattern="smoke")) == ["avoid-pole", "dock"]
    assert names(select_specs(SUITE, pattern="pole or night")) == ["avoid-pole", "dock-at-night"]
    assert names(select_specs(SUITE, pattern="dock and not night")) == ["dock"]


def test_tags_select_specs_that_carry_every_tag() -> None:
    assert names(select_specs(SUITE, tags=["smoke"])) == ["avoid-pole", "dock"]
    assert names(select_specs(SUITE, tags=["obstacles", "smoke"])) == ["avoid-pole"]
    assert names(select_specs(SUITE, tags=["night", "smoke"])) == []


def test_a_pattern_and_tags_both_apply() -> None:
    assert names(select_specs(SUITE, pattern="dock", tags=["night"])) == ["dock-at-night"]


# KeywordExpression: -k read as pytest reads it, words over the names pytest gives a DTC

HEAD_PAT = ("head-pat", "touch", "happy")
PUSH_OVER = ("push-over", "falls")


@pytest.mark.parametrize(
    ("expression", "head_pat", "push_over"),
    [
        ("pat", True, False),
        ("PAT", True, False),
        ("touch", True, False),
        ("touch or push", True, True),
        ("touch and not happy", False, False),
        ("not touch", False, True),
        ("(touch or falls) and over", False, True),
        ("not (pat or over)", False, False),
        ("", True, True),
        ("   ", True, True),
    ],
)
def test_a_word_matches_a_substring_of_one_of_the_names(
    expression: str, head_pat: bool, push_over: bool
) -> None:
    parsed = KeywordExpression.parse(expression)

    assert parsed.matches(HEAD_PAT) is head_pat
    assert parsed.matches(PUSH_OVER) is push_over


@pytest.mark.parametrize(
    ("expression", "problem"),
    [
        ("touch or", "ends where a word was expected"),
        ("(touch", "a '(' is not closed"),
        ("touch pat", "unexpected 'pat'"),
        ("and touch", "expected a word, got 'and'"),
        ("touch)", "unexpected ')'"),
        ("dock*", "unexpected character '*'"),
    ],
)
def test_a_malformed_expression_is_one_line_naming_it(expression: str, problem: str) -> None:
    with pytest.raises(OptionError) as raised:
        KeywordExpression.parse(expression)

    assert str(raised.value) == f"-k {expression!r}: {problem}"
