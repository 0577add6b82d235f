"""Loading ``module:factory`` references: whatever the user's code does, one line naming
the reference and the cause, with the user's traceback kept for ``--verbose``."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

import beatlog
from beatlog.errors import SystemLoadError
from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.random import RecordingRandom
from beatlog.usercode import failure_site, load_factory, load_robot, load_system, user_traceback
from tests.conftest import Probe

LIBRARY = str(Path(beatlog.__file__).parent)


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
    assert LIBRARY not in kept
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


class Stumbling:
    """A user's behavior that raises when stepped; beatlog's arbiter calls it."""

    name = "stumbling"
    state = "upright"

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        raise ZeroDivisionError("stumbled")


def raised_through_beatlog() -> ZeroDivisionError:
    """The exception of a user's behavior, raised through beatlog's arbiter."""
    system = PriorityArbiter([Stumbling()], robot_state=Probe)
    try:
        system.update(Probe(), Context(RecordingRandom(seed=1)))
    except ZeroDivisionError as exc:
        return exc
    raise AssertionError("the behavior did not raise")


def test_the_user_traceback_leaves_out_beatlogs_frames() -> None:
    exc = raised_through_beatlog()
    line = inspect.getsourcelines(Stumbling.step)[1] + 1

    kept = user_traceback(exc)

    assert kept.startswith("Traceback (most recent call last):\n")
    assert f'File "{__file__}", line {line}, in step' in kept
    assert "in raised_through_beatlog" in kept
    assert LIBRARY not in kept
    assert kept.endswith("ZeroDivisionError: stumbled\n")


def test_the_failure_site_is_the_innermost_frame_of_the_users_code() -> None:
    exc = raised_through_beatlog()
    line = inspect.getsourcelines(Stumbling.step)[1] + 1

    assert failure_site(exc) == f"line {line} of {__file__}"


def test_the_failure_site_of_a_syntax_error_is_where_the_error_is(tmp_path: Path) -> None:
    path = write_module(tmp_path, "broken_robot", "x = 1\ndef system(:\n")

    with pytest.raises(SyntaxError) as caught:
        compile(path.read_text(), str(path), "exec")

    assert failure_site(caught.value) == f"line 2 of {path}"


def test_an_exception_never_raised_has_no_failure_site() -> None:
    exc = RuntimeError("made, not raised")

    assert failure_site(exc) is None
    assert (
        user_traceback(exc)
        == "Traceback (most recent call last):\nRuntimeError: made, not raised\n"
    )
