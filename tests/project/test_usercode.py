"""Loading ``module:factory`` references: whatever the user's code does, one line naming
the reference and the cause, with the user's traceback kept for ``--verbose``."""

from __future__ import annotations

import inspect
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

import beatlog
from beatlog.errors import SystemLoadError
from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context, Outputs
from beatlog.model.random import RecordingRandom
from beatlog.project.usercode import (
    failure_site,
    importable_near,
    load_conversion,
    load_factory,
    load_perception,
    load_robot,
    load_system,
    user_traceback,
)
from beatlog.record.recorder import Recorder
from tests.commands import closing_counts
from tests.conftest import Probe
from tests.specs import write_spec
from tests.text import frames, whole_lines

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
    line = re.search(r"\(line (\d+) of ", cause)
    assert line is not None
    function = "system" if cause.startswith("the factory") else "<module>"
    where = f'File "{path}", line {line[1]}' + (
        "" if "SyntaxError" in cause else f", in {function}"
    )
    assert [text.strip() for text in kept.splitlines() if text.lstrip().startswith("File ")] == [
        where
    ]
    assert LIBRARY not in kept
    assert "importlib" not in kept


def test_a_missing_module_names_it_without_a_traceback() -> None:
    with pytest.raises(SystemLoadError) as caught:
        load_factory("beatlog_no_such_robot.arena:system")

    assert str(caught.value).startswith(
        "'beatlog_no_such_robot.arena:system': cannot import beatlog_no_such_robot.arena: "
        "No module named 'beatlog_no_such_robot' (looked in "
    )
    assert caught.value.user_traceback is None


@pytest.mark.parametrize(
    ("reference", "meant"),
    [("tests.conftest:probe_sytem", "probe_system"), ("tests.conftest:Prob", "Probe")],
)
def test_a_missing_factory_names_the_one_it_may_mean(reference: str, meant: str) -> None:
    with pytest.raises(SystemLoadError) as caught:
        load_factory(reference)

    module, _, attribute = reference.partition(":")
    assert str(caught.value) == (
        f"{reference!r}: {module} has no {attribute} (did you mean {meant!r}?)"
    )


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


def test_a_perception_factory_that_builds_no_callable_says_what_it_built(user_dir: Path) -> None:
    write_module(user_dir, "perceives_nothing", "def perception():\n    return 42\n")

    with pytest.raises(
        SystemLoadError, match=r"^'perceives_nothing:perception': built an int, not a perception"
    ):
        load_perception("perceives_nothing:perception")


def test_a_conversion_is_the_function_itself_never_called() -> None:
    from tests.systems import centimetres  # noqa: PLC0415 - the function the reference names

    assert load_conversion("tests.systems:centimetres") is centimetres


@pytest.mark.parametrize(
    ("reference", "problem"),
    [
        ("tests.systems:HEADINGS", "tuple is not a function"),
        ("tests.systems", "expected module:function, e.g. mypkg.compat:percent"),
        (
            "tests.systems:centimeters",
            "tests.systems has no centimeters (did you mean 'centimetres'?)",
        ),
    ],
)
def test_a_conversion_that_is_no_function_is_one_line(reference: str, problem: str) -> None:
    with pytest.raises(SystemLoadError) as caught:
        load_conversion(reference)

    assert str(caught.value) == f"{reference!r}: {problem}"


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
    assert f'File "{__file__}", line {line}, in step' in whole_lines(kept)
    assert (__file__, "raised_through_beatlog") in frames(kept)
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


LINEBOT = """\
from beatlog import PriorityArbiter, RobotState


class Line(RobotState, kw_only=True):
    offset: float = 0.0


class Follow:
    name = "follow"
    state = "centred"

    def step(self, rs, ctx):
        self.state = "steering" if abs(rs.offset) > 0.1 else "centred"
        return None


def system():
    return PriorityArbiter([Follow()], robot_state=Line)
"""


def console_script(name: str) -> str:
    """The path of one of this environment's console scripts (``beatlog``, ``pytest``)."""
    script = shutil.which(name, path=str(Path(sys.executable).parent))
    assert script is not None, f"{name} is not installed beside {sys.executable}"
    return script


@pytest.fixture
def linebot_project(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A user's project as the README suggests: ``myrobot/pyproject.toml``, the robot's
    module ``linebot.py`` at its root, and one DTC in ``myrobot/dtc/``."""
    project = tmp_path / "myrobot"
    project.mkdir()
    (project / "pyproject.toml").write_text('[project]\nname = "myrobot"\n')
    write_module(project, "linebot", LINEBOT)
    log = project / "dtc" / "drift.beatlog"
    log.parent.mkdir()
    monkeypatch.syspath_prepend(str(project))
    line = load_system("linebot:system").robot_state
    with Recorder(log, load_system("linebot:system"), system_ref="linebot:system") as recorder:
        for t in range(40):
            recorder.step(30_000_000, line(offset=(t % 10) / 20))
    write_spec(project / "dtc", "drift", log, "linebot:system")
    return project


def run_from(folder: Path, *command: str) -> subprocess.CompletedProcess[str]:
    """Run a console script in ``folder``, with nothing of this test run on its path."""
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    return subprocess.run(
        command,
        cwd=folder,
        env=environment,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_beatlog_test_imports_a_specs_system_from_its_project_root_anywhere(
    linebot_project: Path,
) -> None:
    done = run_from(
        linebot_project.parent, console_script("beatlog"), "test", "-j", "1", "myrobot/dtc"
    )

    assert done.returncode == 0, done.stderr
    assert closing_counts(done.stdout) == "1 passed, 0 failed"


@pytest.mark.slow  # 2 s or more: CI's slow run has it
def test_the_pytest_console_script_imports_a_specs_system(linebot_project: Path) -> None:
    done = run_from(linebot_project, console_script("pytest"), "-p", "no:cacheprovider", "dtc")

    assert done.returncode == 0, done.stdout
    assert re.fullmatch(r"=+ 1 passed in [\d.]+s =+", done.stdout.splitlines()[-1])


def test_a_spec_imports_from_its_own_folder_without_a_project(tmp_path: Path) -> None:
    folder = tmp_path / "loose"
    folder.mkdir()
    write_module(folder, "linebot_loose", LINEBOT)
    spec = write_spec(folder, "loose", folder / "absent.beatlog", "linebot_loose:system")

    with importable_near(spec):
        assert list(load_system("linebot_loose:system").behaviors) == ["arbiter", "follow"]
    assert str(folder) not in sys.path


def test_a_module_not_found_says_where_it_was_looked_for(linebot_project: Path) -> None:
    (linebot_project / "linebot.py").unlink()
    outside = linebot_project.parent

    done = run_from(outside, console_script("beatlog"), "test", "-j", "1", "myrobot/dtc")

    assert done.returncode == 2
    folders = ", ".join(
        re.escape(str(folder.resolve()))
        for folder in (linebot_project / "dtc", linebot_project, outside)
    )
    assert re.fullmatch(
        r"beatlog: error: drift \(myrobot/dtc/drift\.dtc\.toml\): 'linebot:system': "
        rf"cannot import linebot: No module named 'linebot' \(looked in {folders}(, [^,]+)* "
        r"and the installed packages; a reference imports from the working directory, a spec's "
        r"folder and its project root, the nearest folder above it with a pyproject\.toml\)\n",
        done.stderr,
    ), done.stderr
    looked = done.stderr.partition("(looked in ")[2].partition(" and the installed packages")[0]
    assert os.path.realpath(sysconfig.get_paths()["scripts"]) not in looked.split(", ")
