"""The README is real code: its Python example and its whole tour run as written."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pytest

from beatlog.suite.spec import load_spec

ROOT = Path(__file__).parent.parent
README = ROOT / "README.md"
ENVIRONMENT_SETUP = (". .venv/bin/activate", "pip install ")
"""Tour lines that make the environment; the tests run in one that has it all."""


class Step(NamedTuple):
    """One step of the tour: a shell command and the exit code its comment promises,
    or a file the tour writes (a TOML block whose first line names it)."""

    command: str
    exit_code: int = 0
    file: str | None = None


def tour() -> Iterator[Step]:
    """The tour's steps in order: every bash line, every TOML block that names a file."""
    text = README.read_text(encoding="utf-8")
    start = text.index("## Quick tour")
    section = text[start : text.find("\n## ", start + 1)]
    for kind, block in re.findall(r"```(bash|toml)\n(.*?)```", section, re.DOTALL):
        if kind == "toml":
            name = re.match(r"# (\S+\.toml)\n", block)
            if name is not None:
                yield Step(block, file=name.group(1))
            continue
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip():
                promised = re.search(r"# exit (\d+)", line)
                yield Step(line, int(promised.group(1)) if promised else 0)


def test_the_readme_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL)
    assert blocks, "README.md has no Python example"
    for block in blocks:
        exec(compile(block, str(README), "exec"), {"__name__": "readme"})
    out = capsys.readouterr().out
    assert re.fullmatch(
        r"imported 200 messages on 1 topic into 67 cycles \(2\.01 s\) to \S+/corridor\.beatlog\n"
        r"200 cycles replayed at [\d,]+× real time\n",
        out,
    ), out


def test_the_readme_specs_are_valid_specs(tmp_path: Path) -> None:
    specs = [(step.file, step.command) for step in tour() if step.file is not None]
    assert len(specs) >= 2
    for name, text in specs:
        spec_file = tmp_path / name
        spec_file.parent.mkdir(exist_ok=True)
        spec_file.write_text(text, encoding="utf-8")
        assert load_spec(spec_file).log.parent.resolve() in (tmp_path, tmp_path / "dtc")


def test_the_tour_starts_in_the_first_commands_environment() -> None:
    first = next(tour())
    assert first.command.startswith(". .venv/bin/activate")


@pytest.mark.slow
@pytest.mark.first  # the suite's longest test: a minute
def test_the_readme_tour_runs_as_written(tmp_path: Path) -> None:
    for part in ("examples", "pyproject.toml"):  # the tour runs at the repository's root
        (tmp_path / part).symlink_to(ROOT / part)
    env = {key: value for key, value in os.environ.items() if key != "CI"}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONBREAKPOINT"] = "0"  # the debugger's stops return at once
    ran = 0
    for step in tour():
        if step.file is not None:
            (tmp_path / step.file).write_text(step.command, encoding="utf-8")
            continue
        if step.command.startswith(ENVIRONMENT_SETUP):
            continue
        done = subprocess.run(
            ["bash", "-c", step.command],
            check=False,
            cwd=tmp_path,
            env=env,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == step.exit_code, (step.command, done.stdout, done.stderr)
        ran += 1
    assert ran >= 30
