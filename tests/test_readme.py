"""The README's Python example is real code: it must run as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from beatlog.suite.spec import load_spec

README = Path(__file__).parent.parent / "README.md"


def test_the_readme_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL)
    assert blocks, "README.md has no Python example"
    for block in blocks:
        exec(compile(block, str(README), "exec"), {"__name__": "readme"})
    assert "cycles replayed at" in capsys.readouterr().out


def test_the_readme_spec_is_a_valid_spec(tmp_path: Path) -> None:
    (block,) = re.findall(r"```toml\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL)
    spec_file = tmp_path / "avoid-pole.dtc.toml"
    spec_file.write_text(block, encoding="utf-8")
    spec = load_spec(spec_file)
    assert spec.log == tmp_path / "avoid-pole.beatlog"
