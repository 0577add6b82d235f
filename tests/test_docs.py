"""The documentation: the site builds in strict mode (no broken link, page or docstring)
with its generated pages, its examples run, and the changelog, benchmarks and docstrings
keep their shape."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from beatlog.cli.common import EXIT_CODES

ROOT = Path(__file__).parent.parent


@pytest.mark.slow
def test_the_documentation_builds_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs", reason="the docs extra is not installed")
    pytest.importorskip("mkdocstrings_handlers.python", reason="the docs extra is not installed")
    site = tmp_path / "site"
    built = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        capture_output=True,
        text=True,
        check=False,
    )
    assert built.returncode == 0, built.stderr
    reference = (site / "api" / "log" / "index.html").read_text(encoding="utf-8")
    assert 'id="beatlog.log.SessionLogReader"' in reference
    assert (site / "format" / "index.html").is_file()
    cli = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "usage: beatlog replay" in cli
    assert "usage: beatlog help" in cli
    glossary = (site / "glossary" / "index.html").read_text(encoding="utf-8")
    assert 'id="open-loop"' in glossary
    assert 'id="extra-random-draw"' in glossary
    api = site / "api"
    for page, anchor in [
        ("adapters", 'id="beatlog.adapters.py_trees"'),
        ("model", 'id="beatlog.model.Sample.stamp_ns"'),
        ("model", "the heartbeat's index t, from 0"),
        ("record", "the robot's name, kept in the header"),
        ("suite", "names a callable that takes no"),
    ]:
        assert anchor in (api / page / "index.html").read_text(encoding="utf-8"), (page, anchor)


def test_every_snippet_of_the_own_loop_page_is_the_thermostat_s_code_verbatim() -> None:
    page = (ROOT / "docs" / "own-loop.md").read_text(encoding="utf-8")
    snippets = re.findall(r"```python\n(.*?)```", page, re.DOTALL)
    package = ROOT / "examples" / "src" / "beatlog_examples" / "thermostat"
    source = "".join(path.read_text(encoding="utf-8") for path in sorted(package.glob("*.py")))
    assert len(snippets) == 5
    assert [snippet for snippet in snippets if snippet not in source] == []


@pytest.mark.parametrize(
    "page",
    ["own-system.md", "py-trees.md", pytest.param("ros2-bags.md", marks=pytest.mark.slow)],
)
def test_every_python_example_of_a_how_to_guide_runs(
    page: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (ROOT / "docs" / "how-to" / page).read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.DOTALL)
    assert blocks
    for block in blocks:
        exec(compile(block, page, "exec"), {"__name__": "docs"})


def test_the_changelog_has_one_line_per_entry() -> None:
    lines = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8").splitlines()
    entries = [line for line in lines if line.startswith("- ")]

    assert len(entries) > 100
    assert [line for line in lines if line.startswith("  ")] == [], "an entry runs on"


def test_the_benchmarks_are_one_short_table() -> None:
    text = (ROOT / "BENCHMARKS.md").read_text(encoding="utf-8")

    assert len(text.splitlines()) <= 250
    assert text.count("## Figures") == 1


def test_no_docstring_cites_benchmarks_or_example_logs() -> None:
    cited = re.compile(r"BENCHMARKS\.md|bench/|dog.s logs")
    found = [
        f"{path.relative_to(ROOT)}:{number}"
        for path in sorted((ROOT / "src").rglob("*.py"))
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if cited.search(line)
    ]

    assert found == []


def test_the_exit_codes_page_has_every_code_the_help_pages_end_with() -> None:
    page = (ROOT / "docs" / "reference" / "exit-codes.md").read_text(encoding="utf-8")
    printed = re.findall(r"^  (\d+) ", EXIT_CODES, re.MULTILINE)
    listed = re.findall(r"^\| \*\*(\d+)\*\* \|", page, re.MULTILINE)

    assert len(printed) >= 6
    assert listed == printed
