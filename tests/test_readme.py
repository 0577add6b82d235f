"""The README, the tutorial and the tour are real code: every block runs as written, in
order, with the exit codes and the answers their comments promise."""

from __future__ import annotations

import os
import re
import runpy
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pytest

import beatlog
from beatlog.suite.spec import load_spec

ROOT = Path(__file__).parent.parent
README = ROOT / "README.md"
TUTORIAL = ROOT / "docs" / "tutorial.md"
TOUR = ROOT / "docs" / "tour.md"
ENVIRONMENT_SETUP = (". .venv/bin/activate", "pip install ")
"""Lines that make the environment; the tests run in one that has it all."""


class Step(NamedTuple):
    """One step of a page: a shell command, the exit code its comment promises (``# exit
    N``) and the answer it is given on its input (``# answer a``), or a file the page
    writes (a TOML or Python block whose first line names it)."""

    command: str
    exit_code: int = 0
    file: str | None = None
    answer: str | None = None


def steps(page: Path, section: str | None = None) -> Iterator[Step]:
    """The steps of ``page`` (of its ``## section`` only, when given), in order."""
    text = page.read_text(encoding="utf-8")
    if section is not None:
        start = text.index(f"\n## {section}\n")
        end = text.find("\n## ", start + 1)
        text = text[start : end if end != -1 else None]
    for kind, block in re.findall(r"```(bash|toml|python)\n(.*?)```", text, re.DOTALL):
        if kind != "bash":
            name = re.match(r"# (\S+\.(?:toml|py))\n", block)
            if name is not None:
                yield Step(block, file=name.group(1))
            continue
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip():
                promised = re.search(r"# exit (\d+)", line)
                answer = re.search(r"# answer (\w)\b", line)
                yield Step(
                    line,
                    int(promised.group(1)) if promised else 0,
                    answer=answer.group(1) if answer else None,
                )


def run_steps(page_steps: Iterator[Step], cwd: Path) -> int:
    """Run the steps in ``cwd`` as a reader would, in this environment: write each file,
    run each command with its promised exit code and answer. Returns the commands run."""
    env = {key: value for key, value in os.environ.items() if key != "CI"}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONBREAKPOINT"] = "0"  # the debugger's stops return at once
    ran = 0
    for step in page_steps:
        if step.file is not None:
            (cwd / step.file).parent.mkdir(parents=True, exist_ok=True)
            (cwd / step.file).write_text(step.command, encoding="utf-8")
            continue
        if step.command.startswith(ENVIRONMENT_SETUP):
            continue
        done = subprocess.run(
            ["bash", "-c", step.command],
            check=False,
            cwd=cwd,
            env=env,
            input=None if step.answer is None else f"{step.answer}\n",
            stdin=subprocess.DEVNULL if step.answer is None else None,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == step.exit_code, (step.command, done.stdout, done.stderr)
        ran += 1
    return ran


def at_the_repository_root(tmp_path: Path) -> Path:
    """A folder that stands in for the repository's root: its examples and pyproject.toml."""
    for part in ("examples", "pyproject.toml"):
        (tmp_path / part).symlink_to(ROOT / part)
    return tmp_path


def files(page: Path) -> dict[str, str]:
    """The files a page writes, by name."""
    return {step.file: step.command for step in steps(page) if step.file is not None}


def test_the_readme_starts_with_its_two_set_up_commands_and_stays_short() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()

    assert len(lines) <= 150
    assert lines[2] == "```bash"
    assert lines[3].startswith("python3 -m venv .venv && ")
    assert lines[4].startswith("python3 -m venv .venv && ")
    assert lines[4].endswith("pytest -n auto")


def test_every_link_of_the_readme_leads_to_a_file_of_the_repository() -> None:
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README.read_text(encoding="utf-8"))
    local = [link for link in links if "://" not in link]

    assert len(local) >= 20
    assert [link for link in local if not (ROOT / link).is_file()] == []


def test_the_readme_robot_records_and_replays_as_a_dtc(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name, text in files(README).items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "argv", ["run_robot.py", "walk.beatlog"])
    monkeypatch.setattr(time, "sleep", lambda seconds: None)  # the loop's wait for the next beat
    try:
        runpy.run_path("run_robot.py", run_name="__main__")
        spec = load_spec(tmp_path / "walk.dtc.toml")
        myrobot = sys.modules["myrobot"]
        result = beatlog.replay(spec.log, myrobot.system())
    finally:
        sys.modules.pop("myrobot", None)

    assert (spec.system, spec.log) == ("myrobot:system", tmp_path / "walk.beatlog")
    assert result.ok, result.divergence
    assert result.cycles == 100


def test_the_readme_robot_is_the_tutorial_s() -> None:
    readme = files(README)

    assert sorted(readme) == ["myrobot.py", "run_robot.py", "walk.dtc.toml"]
    assert {name: files(TUTORIAL)[name] for name in readme} == readme


@pytest.mark.parametrize("page", sorted([README, *(ROOT / "docs").rglob("*.md")]))
def test_every_toml_block_says_which_file_it_is(page: Path) -> None:
    blocks = re.findall(r"```toml\n(.*?)```", page.read_text(encoding="utf-8"), re.DOTALL)

    assert [block for block in blocks if not re.match(r"# \S+\.toml\b", block)] == []


def test_the_tour_s_specs_are_valid_specs(tmp_path: Path) -> None:
    specs = {name: text for name, text in files(TOUR).items() if name.endswith(".toml")}
    assert len(specs) >= 2
    for name, text in specs.items():
        spec_file = tmp_path / name
        spec_file.parent.mkdir(exist_ok=True)
        spec_file.write_text(text, encoding="utf-8")
        assert load_spec(spec_file).log.parent.resolve() in (tmp_path, tmp_path / "dtc")


def test_the_tour_starts_in_the_set_up_command_s_environment() -> None:
    assert next(steps(TOUR)).command.startswith(". .venv/bin/activate")


def test_the_tutorial_answers_the_review_and_approves_nothing_after() -> None:
    commands = [step for step in steps(TUTORIAL) if step.file is None]
    reviews = [index for index, step in enumerate(commands) if "beatlog review" in step.command]

    assert [commands[index].answer for index in reviews] == ["a"]
    assert not any("beatlog approve" in step.command for step in commands)


@pytest.mark.slow
def test_the_readme_robot_runs_as_written(tmp_path: Path) -> None:
    assert run_steps(steps(README, "Add beatlog to your robot"), tmp_path) == 3


@pytest.mark.slow
def test_the_readme_five_commands_run_as_written(tmp_path: Path) -> None:
    assert run_steps(steps(README, "Five commands"), at_the_repository_root(tmp_path)) == 5


@pytest.mark.slow
def test_the_tutorial_runs_as_written(tmp_path: Path) -> None:
    assert run_steps(steps(TUTORIAL), tmp_path) >= 12
    assert (tmp_path / "walk.dtc.expected").is_file()
    assert not (tmp_path / "walk.dtc.pending").exists()


@pytest.mark.slow
@pytest.mark.first  # the suite's longest test: minutes
def test_the_tour_runs_as_written(tmp_path: Path) -> None:
    assert run_steps(steps(TOUR), at_the_repository_root(tmp_path)) >= 40
