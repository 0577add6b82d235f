"""Catches behavior code reading the wall clock or a global random number generator.

A :class:`LeakWatch` entered around a system's update sees, through a profile hook,
every call of a builtin and of a Python function, however a behavior module bound it
(``from time import monotonic`` too). numpy's compiled functions are invisible to it,
so a trace hook follows the lines of user code and notices when numpy's global
generator moved, or an unseeded one of the system's own (:func:`built_watched`). Each
call is put on the nearest frame of user code (not beatlog's, the standard library's
or an installed package's: :class:`Origins`), or of a package where no user code led
there. What is watched, and what not: :mod:`beatlog.project.watched`.
"""

from __future__ import annotations

import collections
import cProfile
import enum
import logging
import os
import random
import site
import sys
import sysconfig
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import CodeType, FrameType
from typing import Any, TypeVar

from beatlog.project.watched import (
    ENTROPY_READ,
    GlobalNumpyGenerator,
    PrivateGenerator,
    builtin_call,
    python_calls,
    screened_builtins,
)

__all__ = ["Finding", "LeakScreen", "LeakWatch", "Origin", "Origins", "built_watched"]

T = TypeVar("T")


class Origin(enum.Enum):
    """Who wrote the code a frame runs."""

    USER = enum.auto()
    """The code under test: a finding's site."""
    LIBRARY = enum.auto()
    """An installed package: a site only when no user code called it."""
    EXEMPT = enum.auto()
    """beatlog itself or the standard library."""


def _folders(*paths: str) -> tuple[str, ...]:
    return tuple(str(Path(path).resolve()) + os.sep for path in paths if path)


class Origins:
    """Classifies source files by origin, once per file."""

    def __init__(self) -> None:
        paths = sysconfig.get_paths()
        (self._beatlog,) = _folders(str(Path(__file__).parent.parent))
        self._libraries = _folders(
            paths["purelib"], paths["platlib"], *site.getsitepackages(), site.getusersitepackages()
        )
        self._stdlib = _folders(paths["stdlib"], paths["platstdlib"])
        (self._logging,) = _folders(str(Path(logging.__file__).parent))
        self._known: dict[str, Origin] = {}

    def of(self, code: CodeType) -> Origin:
        origin = self._known.get(code.co_filename)
        if origin is None:
            origin = self._known[code.co_filename] = self._classify(code.co_filename)
        return origin

    def _classify(self, filename: str) -> Origin:
        if filename.startswith("<"):  # frozen modules, exec'd strings
            return Origin.EXEMPT
        path = str(Path(filename).resolve())
        if path.startswith(self._beatlog):
            return Origin.EXEMPT
        if path.startswith(self._libraries):
            return Origin.LIBRARY
        return Origin.EXEMPT if path.startswith(self._stdlib) else Origin.USER

    def is_logging(self, code: CodeType) -> bool:
        return code.co_filename.startswith(self._logging)


@dataclass(frozen=True)
class Finding:
    """A call that made replay depend on the wall clock or a global random generator."""

    call: str
    """What was called, e.g. ``time.monotonic`` or ``random.choice``."""
    site: str
    """The line that made the call, ``file:line in function``: user code, or an installed
    package (py_trees' timers, say) when the call is made there."""
    count: int
    """How many times it was called during replay."""
    via: str | None = None
    """When ``site`` is in an installed package, the first frame of user code that led
    there (``file:line in function``); None when ``site`` is user code or none led there."""

    def __str__(self) -> str:
        """``random.choice at FILE:LINE in FUNCTION (12 times)``, then where user code
        led there when the site is a package's."""
        times = "once" if self.count == 1 else f"{self.count:,} times"
        return f"{self.call} at {self.site} ({times})" + (
            "" if self.via is None else f", from {self.via}"
        )


Where = tuple[CodeType, int]


def _site(where: Where) -> str:
    code, line = where
    return f"{code.co_filename}:{line} in {code.co_qualname}"


class _Watch:
    """What a watch and a screen share: numpy's global generator and the system's own
    unseeded ones (:attr:`generators`, from :func:`built_watched`), marked where they
    stand on entering (draws between updates are the framework's or the test's), and
    whether one moved inside (:attr:`numpy_moved`)."""

    def __init__(self) -> None:
        self._numpy = GlobalNumpyGenerator()
        self.generators: Sequence[PrivateGenerator] = ()
        self.numpy_moved = False

    def _moved(self) -> list[str]:
        """The generators that moved since last asked, each marked where it stands now."""
        return [g.name for g in (self._numpy, *self.generators) if g.moved()]

    def findings(self) -> list[Finding]:
        """What was caught so far, in the order first seen (a screen catches nothing:
        it only says whether a watch is needed)."""
        return []


class LeakWatch(_Watch):
    """Counts wall-clock reads and global random calls made by code called inside it.

    Enter it around each update of the system under test; calls made directly by the
    frame that enters it, or outside it, are not counted. With ``lines`` off it follows
    no lines (the costliest hook by far): numpy's global generator is then only checked
    on leaving, and :attr:`numpy_moved` says whether it moved inside, so that a second
    replay with ``lines`` on can find where.
    """

    def __init__(self, *, lines: bool = True) -> None:
        super().__init__()
        self._lines = lines
        self._origins = Origins()
        self._python_calls = python_calls()
        self._counts: collections.Counter[tuple[str, str, str | None]] = collections.Counter()
        self._boundary: FrameType | None = None
        self._inside: FrameType | None = None
        self._where: Where | None = None
        self._saved: tuple[Any, Any] = (None, None)

    def findings(self) -> list[Finding]:
        return [
            Finding(call, site, count, via) for (call, site, via), count in self._counts.items()
        ]

    def __enter__(self) -> LeakWatch:
        self._boundary = sys._getframe(1)  # the frame that runs the update
        self._moved()
        self._inside = None
        self._where = None
        self._saved = (sys.getprofile(), sys.gettrace())
        if self._lines:
            sys.settrace(self._trace)
        sys.setprofile(self._profile)
        return self

    def __exit__(self, *exc_info: object) -> None:
        profile, trace = self._saved
        sys.setprofile(profile)
        sys.settrace(trace)
        self._boundary = None
        if not self._lines:
            self.numpy_moved |= bool(self._moved())

    def _profile(self, frame: FrameType, event: str, arg: Any) -> None:
        if event == "c_call":
            if self._inside is None:
                call = builtin_call(arg)
                if call is not None:
                    self._count(call, frame)
        elif event == "call":
            if self._inside is None:
                call = self._python_call(frame)
                if call is not None:
                    self._inside = frame  # its own calls (getrandbits, urandom) are not counted
                    if frame.f_back is not None:
                        self._count(call, frame.f_back)
        elif event == "return" and frame is self._inside:
            self._inside = None

    def _python_call(self, frame: FrameType) -> str | None:
        call = self._python_calls.get(frame.f_code)
        if call is not None and call.startswith("random."):
            return call if frame.f_locals.get("self") is random._inst else None
        return call

    def _trace(self, frame: FrameType, event: str, arg: Any) -> Any:
        if self._origins.of(frame.f_code) is not Origin.USER:
            return None
        self._check_numpy()
        self._where = (frame.f_code, frame.f_lineno)
        return self._trace_lines

    def _trace_lines(self, frame: FrameType, event: str, arg: Any) -> Any:
        if event == "line":
            self._check_numpy()
            self._where = (frame.f_code, frame.f_lineno)
        elif event == "return":
            self._check_numpy()
            if frame.f_back is not None:  # the nearest user frame, else a package's
                site, via = self._culprit(frame.f_back)
                self._where = via or site
        return self._trace_lines

    def _check_numpy(self) -> None:
        for name in self._moved():
            if self._where is not None:
                self._counts[name, _site(self._where), None] += 1

    def _count(self, call: str, caller: FrameType) -> None:
        if self._origins.is_logging(caller.f_code):
            return
        site, via = self._culprit(caller)
        if site is not None:
            self._counts[call, _site(site), None if via is None else _site(via)] += 1

    def _culprit(self, frame: FrameType | None) -> tuple[Where | None, Where | None]:
        """The line that made the call (the nearest frame of user code or of an installed
        package below the boundary) and, when that is a package's, the first frame of
        user code that led there."""
        site: Where | None = None
        while frame is not None and frame is not self._boundary:
            origin = self._origins.of(frame.f_code)
            if origin is Origin.USER:
                where = frame.f_code, frame.f_lineno
                return (where, None) if site is None else (site, where)
            if origin is Origin.LIBRARY and site is None:
                site = frame.f_code, frame.f_lineno
            frame = frame.f_back
        return site, None


class LeakScreen(_Watch):
    """A cheap first look: does code called inside it make any call a :class:`LeakWatch`
    counts, or move numpy's global generator?

    Enter it around each update, like a watch. It profiles with :mod:`cProfile`, whose
    hook is written in C, and afterwards looks for the watched functions among the
    functions called, whoever called them: it cannot say where or how often, nor tell
    the global ``random`` instance's builtin methods from a private instance's. A clean
    screen means a watch would find nothing; anything else is for a watch to look at.
    """

    def __init__(self) -> None:
        super().__init__()
        self._profiler = cProfile.Profile()

    def __enter__(self) -> LeakScreen:
        self._moved()
        self._profiler.enable()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._profiler.disable()
        self.numpy_moved |= bool(self._moved())

    @property
    def suspicious(self) -> bool:
        """Whether a watched function was called, or numpy's global generator moved."""
        if self.numpy_moved:
            return True
        calls = python_calls()
        builtins = screened_builtins()
        return any(
            entry.code in builtins if isinstance(entry.code, str) else entry.code in calls
            for entry in self._profiler.getstats()
        )


def built_watched(build: Callable[[], T]) -> tuple[T, list[PrivateGenerator]]:
    """What ``build`` builds (a system), and the numpy generators of its own that it
    seeded from the OS, each named by the line of user code that made it, for a watch
    or a screen to watch (their :attr:`~LeakWatch.generators`).

    A profile hook notes the entropy each generator made without a seed reads (numpy
    reads it with ``secrets.randbits``) and the nearest line of user code that read it;
    the generators keeping those entropies are then looked for in what was built. numpy
    is imported first, where installed: its own global generator reads entropy too.
    """
    GlobalNumpyGenerator()  # imports numpy.random, where installed
    origins = Origins()
    boundary = sys._getframe(0)
    made: dict[int, str] = {}

    def profile(frame: FrameType, event: str, arg: Any) -> None:
        if event == "return" and frame.f_code is ENTROPY_READ and isinstance(arg, int):
            caller = frame.f_back
            while caller is not None and caller is not boundary:
                if origins.of(caller.f_code) is Origin.USER:
                    made[arg] = _site((caller.f_code, caller.f_lineno))
                    return
                caller = caller.f_back

    saved = sys.getprofile()
    sys.setprofile(profile)
    try:
        built = build()
    finally:
        sys.setprofile(saved)
    return built, PrivateGenerator.found(built, made) if made else []
