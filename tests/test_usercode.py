"""Loading ``module:factory`` references: whatever the user's code does, one line naming
the reference and the cause, with the user's traceback kept for ``--verbose``."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import SystemLoadError
from beatlog.usercode import load_factory, load_robot, load_system


def write_module(directory: Path, name: str, source: str) -> Path:
    """A user's robot module, importable from ``directory``."""
    path = directory / f"{name}.py"
    path.write_text(source)
    return path


@pytest.fixture
def user_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


CASES = [
    pytest.param(
        "ratio = 1\nratio = ratio / 0\n",
        "importing {m} raised ZeroDivisionError: division by zero (line 2 of {f})",
        id="module-raises",
    ),
    pytest.param(
        "def system(:\n",
        "importing {m} raised SyntaxError: invalid syntax (line 1 of {f})",
        id="syntax-error",
    ),
    pytest.param(
        "import beatlog_no_such_dependency\n",
        "importing {m} raised ModuleNotFoundError: No module named "
        "'beatlog_no_such_dependency' (line 1 of {f})",
        id="missing-dependency",
    ),
    pytest.param(
        "import sys\nsys.exit('no arena here')\n",
        "importing {m} called sys.exit('no arena here') (line 2 of {f})",
        id="module-exits",
    ),
    pytest.param(
        "def system():\n    raise RuntimeError('the arena\\nmap is missing')\n",
        "the factory raised RuntimeError: the arena map is missing (line 2 of {f})",
        id="factory-raises",
    ),
    pytest.param(
        "import sys\n\ndef system():\n    sys.exit(3)\n",
        "the factory called sys.exit(3) (line 4 of {f})",
        id="factory-exits",
    ),
]


@pytest.mark.parametrize(("source", "cause"), CASES)
def test_user_code_that_fails_is_one_line_naming_the_reference_and_the_cause(
    user_dir: Path, request: pytest.FixtureRequest, source: str, cause: str
) -> None:
    module = f"robot_{request.node.callspec.id.replace('-', '_')}"
    path = write_module(user_dir, module, source)
    reference = f"{module}:system"

    with pytest.raises(SystemLoadError) as caught:
        load_system(reference)

    message = str(caught.value)
    assert message == f"{reference!r}: " + cause.format(m=module, f=path)
    assert "\n" not in message


@pytest.mark.parametrize(("source", "cause"), CASES)
def test_the_users_traceback_is_kept_without_beatlogs_frames(
    user_dir: Path, request: pytest.FixtureRequest, source: str, cause: str
) -> None:
    module = f"kept_{request.node.callspec.id.replace('-', '_')}"
    path = write_module(user_dir, module, source)

    with pytest.raises(SystemLoadError) as caught:
        load_system(f"{module}:system")

    kept = caught.value.user_traceback
    assert kept is not None
    assert kept.startswith("Traceback (most recent call last):\n")
    assert f'File "{path}", line' in kept
    assert "beatlog/engine" not in kept
    assert "importlib" not in kept


def test_a_missing_module_names_it_without_a_traceback() -> None:
    with pytest.raises(SystemLoadError) as caught:
        load_factory("beatlog_no_such_robot.arena:system")

    assert str(caught.value) == (
        "'beatlog_no_such_robot.arena:system': cannot import beatlog_no_such_robot.arena: "
        "No module named 'beatlog_no_such_robot'"
    )
    assert caught.value.user_traceback is None


def test_ctrl_c_in_a_factory_stays_an_interrupt(user_dir: Path) -> None:
    write_module(user_dir, "robot_interrupted", "def system():\n    raise KeyboardInterrupt\n")

    with pytest.raises(KeyboardInterrupt):
        load_system("robot_interrupted:system")


@pytest.mark.parametrize(
    ("returns", "problem"),
    [
        ("None", "returned None, not a system"),
        ("42", "built an int, not a system"),
        ("{}", "built a dict, not a system"),
    ],
)
def test_a_factory_that_builds_the_wrong_thing_says_what_it_built(
    user_dir: Path, returns: str, problem: str
) -> None:
    module = f"robot_returns_{abs(hash(returns))}"
    write_module(user_dir, module, f"def system():\n    return {returns}\n")

    with pytest.raises(SystemLoadError, match=f"^'{module}:system': {problem} "):
        load_system(f"{module}:system")


def test_a_system_is_not_a_robot() -> None:
    reference = "beatlog_examples.rover:system"

    with pytest.raises(SystemLoadError, match=f"^'{reference}': built a PriorityArbiter, not a"):
        load_robot(reference)
