"""The documentation site builds in strict mode: no broken link, page or docstring."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

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
