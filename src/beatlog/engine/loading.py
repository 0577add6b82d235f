"""Import a system or robot from a ``module:factory`` reference given by the user.

Only references a user types are imported; a log's recorded reference is shown to
people but never imported, so loading a log cannot run code.

Whatever the user's code does while it is imported or called (raise, fail to
compile, call ``sys.exit``) becomes a :class:`~beatlog.errors.SystemLoadError`
whose message is one line naming the reference and the cause, with the user's
traceback kept on it; only ``KeyboardInterrupt`` goes through.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

from beatlog.engine.usercode import failure_site, user_traceback
from beatlog.errors import SystemLoadError
from beatlog.model.behavior import System
from beatlog.model.robot import Robot

__all__ = ["load_factory", "load_robot", "load_system"]


def load_factory(reference: str) -> Any:
    """Import ``module:attribute`` and return the attribute called (if callable)."""
    module_name, sep, attribute = reference.partition(":")
    if not sep or not module_name or not attribute:
        raise SystemLoadError(f"{reference!r}: expected module:factory, e.g. mypkg.robot:system")
    factory: Any = _import(reference, module_name)
    for part in attribute.split("."):
        try:
            factory = getattr(factory, part)
        except AttributeError:
            raise SystemLoadError(f"{reference!r}: {module_name} has no {attribute}") from None
    if not callable(factory):
        return factory
    try:
        return factory()
    except (Exception, SystemExit) as exc:
        raise _failed(reference, "the factory", exc) from None


def _import(reference: str, module_name: str) -> ModuleType:
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and (module_name + ".").startswith(exc.name + "."):
            raise SystemLoadError(f"{reference!r}: cannot import {module_name}: {exc}") from None
        raise _failed(reference, f"importing {module_name}", exc) from None
    except (Exception, SystemExit) as exc:
        raise _failed(reference, f"importing {module_name}", exc) from None


def _failed(reference: str, doing: str, exc: BaseException) -> SystemLoadError:
    """One line for user code that raised or exited, its traceback kept for ``--verbose``."""
    if isinstance(exc, SystemExit):
        cause = f"called sys.exit({exc.code!r})"
    elif isinstance(exc, SyntaxError):
        cause = f"raised SyntaxError: {exc.msg}"
    else:
        message = " ".join(str(exc).split())  # one line, whatever the message holds
        cause = f"raised {type(exc).__name__}" + (f": {message}" if message else "")
    site = failure_site(exc)
    where = f" ({site})" if site else ""
    return SystemLoadError(
        f"{reference!r}: {doing} {cause}{where}", user_traceback=user_traceback(exc)
    )


def load_system(reference: str) -> System:
    """Build the system a ``module:factory`` reference names, checking it is one."""
    system = load_factory(reference)
    if not isinstance(system, System):
        raise SystemLoadError(
            f"{reference!r}: {_built(system)}, not a system "
            "(it needs robot_state, behaviors and update)"
        )
    return system


def load_robot(reference: str) -> Robot:
    """Build the robot a ``module:factory`` reference names, checking it is one."""
    robot = load_factory(reference)
    if not isinstance(robot, Robot):
        raise SystemLoadError(
            f"{reference!r}: {_built(robot)}, not a robot "
            "(it needs system, inbox, start, stop, perceive and act)"
        )
    return robot


def _built(thing: object) -> str:
    if thing is None:
        return "returned None"
    name = type(thing).__name__
    return f"built {'an' if name[0].lower() in 'aeiou' else 'a'} {name}"
