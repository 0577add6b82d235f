"""User code: the systems, robots, perception steps, conversions and invariants that
``module:factory`` (``module:function``, ``module:attribute``) references name, and
where that code failed (its traceback cut down to the user's frames).

Only references the user names are imported (a log's recorded one only when the
project lists it, :mod:`beatlog.project.config`): reading a log never runs code. A
reference imports from ``sys.path``, to which the CLI adds the working directory and a
spec its folder and project root (:func:`importable_near`). A factory that takes a
keyword ``random`` is handed the random source to draw its set-up from (seed 0 where
none is given). Whatever the user's code raises, or ``sys.exit``, becomes one
:class:`~beatlog.errors.SystemLoadError` line, the user's traceback kept on it; only
``KeyboardInterrupt`` goes through.
"""

from __future__ import annotations

import contextlib
import difflib
import importlib
import os
import sys
import sysconfig
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

from beatlog.errors import SystemLoadError
from beatlog.log.files import project_root
from beatlog.model.behavior import System
from beatlog.model.perception import Perception
from beatlog.model.random import RecordingRandom
from beatlog.model.robot import Robot
from beatlog.model.setup import takes_random
from beatlog.model.source import RandomSource

__all__ = [
    "failure",
    "failure_site",
    "importable_near",
    "load_conversion",
    "load_factory",
    "load_invariant",
    "load_perception",
    "load_robot",
    "load_system",
    "user_traceback",
]

_NOT_USERS = (
    str(Path(__file__).parent.parent) + os.sep,  # beatlog's own
    str(Path(importlib.__file__).parent),  # the import machinery's
    "<frozen importlib",
)


def _user_frames(exc: BaseException) -> list[traceback.FrameSummary]:
    """The frames of ``exc``'s traceback in the user's code."""
    frames = traceback.extract_tb(exc.__traceback__)
    return [frame for frame in frames if not frame.filename.startswith(_NOT_USERS)]


def user_traceback(exc: BaseException) -> str:
    """The traceback with beatlog's own frames left out, so it starts in the user's code."""
    lines = ["Traceback (most recent call last):\n", *traceback.format_list(_user_frames(exc))]
    lines.extend(traceback.format_exception_only(exc))
    return "".join(lines)


def failure_site(exc: BaseException) -> str | None:
    """``line N of FILE`` where the user's code failed: the innermost user frame, or
    where a syntax error is; None when no user frame is known."""
    if isinstance(exc, SyntaxError) and exc.filename and exc.lineno:
        return f"line {exc.lineno} of {exc.filename}"
    frames = _user_frames(exc)
    if not frames:
        return None
    return f"line {frames[-1].lineno} of {frames[-1].filename}"


def load_factory(reference: str, *, random: RandomSource | None = None) -> Any:
    """Import ``module:attribute`` and return the attribute called (if callable), with
    ``random=`` where it takes the random source (see the module's docstring)."""
    factory = _attribute(reference, "module:factory, e.g. mypkg.robot:system")
    if not callable(factory):
        return factory
    try:
        if takes_random(factory):
            return factory(random=RecordingRandom(0) if random is None else random)
        return factory()
    except (Exception, SystemExit) as exc:
        raise _failed(reference, "the factory", exc) from None


def load_conversion(reference: str) -> Callable[[Any], Any]:
    """Import the function a ``module:function`` reference names, without calling it: a
    robot-state field's conversion from its recorded type (see
    :class:`beatlog.replay.fit.migration.StateMigration`)."""
    function = _attribute(reference, "module:function, e.g. mypkg.compat:percent")
    if not callable(function):
        raise SystemLoadError(f"{reference!r}: {type(function).__name__} is not a function")
    return function  # type: ignore[no-any-return]


def load_invariant(reference: str) -> Callable[[Any], object]:
    """Import the invariant a ``module:attribute`` reference names: a function, as is,
    or a class, instantiated (afresh at each load, so each replay has its own)."""
    found = _attribute(reference, "module:attribute, e.g. mypkg.invariants:never_fall")
    if isinstance(found, type):
        try:
            found = found()
        except (Exception, SystemExit) as exc:
            raise _failed(reference, "building the invariant", exc) from None
    if not callable(found):
        raise SystemLoadError(f"{reference!r}: {type(found).__name__} is not callable")
    return found  # type: ignore[no-any-return]


def _attribute(reference: str, expected: str) -> Any:
    """What ``module:attribute`` names, imported (the attribute may be dotted)."""
    module_name, sep, attribute = reference.partition(":")
    if not sep or not module_name or not attribute:
        raise SystemLoadError(f"{reference!r}: expected {expected}")
    found: Any = _import(reference, module_name)
    for part in attribute.split("."):
        try:
            found = getattr(found, part)
        except AttributeError:
            near = difflib.get_close_matches(part, dir(found), n=1)
            meant = f" (did you mean {near[0]!r}?)" if near else ""
            raise SystemLoadError(
                f"{reference!r}: {module_name} has no {attribute}{meant}"
            ) from None
    return found


def _import(reference: str, module_name: str) -> ModuleType:
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module_name + ".").startswith(exc.name + "."):
            raise SystemLoadError(
                f"{reference!r}: cannot import {module_name}: {exc} "
                f"(looked in {_searched()} and the installed packages; a reference imports "
                "from the working directory, a spec's folder and its project root, the "
                "nearest folder above it with a pyproject.toml)"
            ) from None
        raise _failed(reference, f"importing {module_name}", exc) from None
    except (Exception, SystemExit) as exc:
        raise _failed(reference, f"importing {module_name}", exc) from None


def _searched() -> str:
    """The folders of ``sys.path`` that hold the user's code, not Python's or packages'."""
    installed = {
        os.path.realpath(path)
        for key in ("stdlib", "platstdlib", "purelib", "platlib", "scripts")
        if (path := sysconfig.get_paths().get(key))
    }
    folders: list[str] = []
    for entry in sys.path:
        folder = os.path.realpath(entry or os.getcwd())
        if not os.path.isdir(folder) or folder in installed or folder in folders:
            continue
        if any(folder.startswith(prefix + os.sep) for prefix in installed):
            continue
        folders.append(folder)
    return ", ".join(folders) if folders else "no folder of your own"


@contextlib.contextmanager
def importable_near(path: Path | None) -> Iterator[None]:
    """While inside, references also import from ``path``'s folder and its project root.

    So a spec's ``system = "linebot:system"`` imports ``linebot.py`` beside the spec or
    at the root of its project, from any working directory and under the ``pytest``
    console script alike. The folders are put first on ``sys.path``, as pytest's
    default import mode puts a test's root there, and taken off again afterwards.
    ``None`` (a fleet log, which has no spec) adds nothing: a log's folder never goes
    on ``sys.path``, so code planted beside downloaded logs is never imported.
    """
    if path is None:
        yield
        return
    folder = path.resolve().parent
    root = project_root(folder)
    added = [str(found) for found in (folder, root) if found is not None]
    added = [entry for entry in dict.fromkeys(added) if entry not in sys.path]
    sys.path[:0] = added
    try:
        yield
    finally:
        for entry in added:
            if entry in sys.path:
                sys.path.remove(entry)


def failure(exc: BaseException) -> str:
    """What the user's code did, in one line: ``raised ValueError: no dock (line 3 of
    robot.py)``, or ``called sys.exit(2)``."""
    if isinstance(exc, SystemExit):
        cause = f"called sys.exit({exc.code!r})"
    elif isinstance(exc, SyntaxError):
        cause = f"raised SyntaxError: {exc.msg}"
    else:
        message = " ".join(str(exc).split())  # one line, whatever the message holds
        cause = f"raised {type(exc).__name__}" + (f": {message}" if message else "")
    site = failure_site(exc)
    return f"{cause} ({site})" if site else cause


def _failed(reference: str, doing: str, exc: BaseException) -> SystemLoadError:
    """One line for user code that raised or exited, its traceback kept for ``--verbose``."""
    return SystemLoadError(
        f"{reference!r}: {doing} {failure(exc)}", user_traceback=user_traceback(exc)
    )


def load_system(reference: str, *, random: RandomSource | None = None) -> System:
    """Build the system a ``module:factory`` reference names, checking it is one; a
    factory that takes ``random`` draws its set-up from ``random``."""
    system = load_factory(reference, random=random)
    if isinstance(system, System):
        return system
    raise _not_a(reference, system, "a system (it needs robot_state, behaviors and update)")


def load_robot(reference: str, *, random: RandomSource | None = None) -> Robot:
    """Build the robot a ``module:factory`` reference names, checking it is one; a
    factory that takes ``random`` draws its system's set-up from ``random``."""
    robot = load_factory(reference, random=random)
    if isinstance(robot, Robot):
        return robot
    raise _not_a(
        reference, robot, "a robot (it needs system, inbox, start, stop, perceive and act)"
    )


def _not_a(reference: str, built: object, wanted: str) -> SystemLoadError:
    """The error for a factory that built something other than ``wanted``."""
    name = type(built).__name__
    what = (
        "returned None"
        if built is None
        else f"built {'an' if name[0] in 'aeiouAEIOU' else 'a'} {name}"
    )
    return SystemLoadError(f"{reference!r}: {what}, not {wanted}")


def load_perception(reference: str) -> Perception:
    """Build the perception step a ``module:factory`` reference names, checking it is one."""
    perception = load_factory(reference)
    if not callable(perception):
        raise _not_a(
            reference,
            perception,
            "a perception step (a callable taking the previous robot state and the samples)",
        )
    return perception  # type: ignore[no-any-return]
