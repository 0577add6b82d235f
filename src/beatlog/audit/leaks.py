"""Catches behavior code reading the wall clock or a global random number generator.

A :class:`LeakWatch` is entered around a system's update in an audited replay. Its
profile hook sees every call of a builtin and of a Python function, so it catches
``time.monotonic`` or ``random.choice`` however a behavior module bound them
(``from time import monotonic`` included). numpy's compiled functions are invisible to
profiling, so a trace hook follows the lines of user code instead and notices when
numpy's global generator moved. Every call is attributed to the nearest frame of
user code: not beatlog's own, not the standard library, not an
installed package; or, when no user code is on the way (a system that is itself an
installed package), to the nearest frame of an installed package.

Watched: ``time.time``, ``monotonic``, ``perf_counter``, ``process_time``,
``thread_time``, ``clock_gettime`` and their ``_ns`` forms; ``now``, ``utcnow`` and
``today`` of ``datetime.datetime`` and ``datetime.date``; every method of the global
``random`` instance (``random.random``, ``random.choice``, ``random.seed``, ...);
numpy's global generator (``np.random.rand``, ``np.random.seed``, ..., reported as
``numpy.random`` once per line of user code that moved it, so not at all in a system
with no user code; a legacy ``np.random.normal`` that returns its cached second value
moves nothing and goes uncounted); ``os.urandom``
(so ``secrets`` too); ``uuid.uuid1`` and ``uuid.uuid4``. Not watched: the forms of
``time.localtime``, ``gmtime``, ``ctime`` and ``strftime`` that read the clock when
given no time (their arguments are invisible to a profile hook), unseeded private
generators (``random.Random()``, ``np.random.default_rng()``), other threads, and the
clock reads of the ``logging`` package (record timestamps reach no decision).
"""

from __future__ import annotations

import collections
import cProfile
import ctypes
import datetime as dt
import enum
import functools
import logging
import os
import random
import site
import sys
import sysconfig
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from types import CodeType, FrameType, TracebackType
from typing import Any

__all__ = ["Finding", "LeakScreen", "LeakWatch"]

_CLOCKS = frozenset(
    f"{name}{suffix}"
    for name in (
        "time",
        "monotonic",
        "perf_counter",
        "process_time",
        "thread_time",
        "clock_gettime",
    )
    for suffix in ("", "_ns")
)
_NOW = frozenset({"now", "utcnow", "today"})
_URANDOM_OWNER = getattr(os.urandom, "__self__", None)
_MT19937_POSITION = 624 * 4
"""Offset of ``pos`` after the 624-word key in numpy's ``mt19937_state``."""


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


class _Origin(enum.Enum):
    """Who wrote the code a frame runs."""

    USER = enum.auto()
    """The code under test: a finding's site."""
    LIBRARY = enum.auto()
    """An installed package: a site only when no user code called it."""
    EXEMPT = enum.auto()
    """beatlog itself or the standard library."""


_BEATLOG_DIR = str(Path(__file__).resolve().parent.parent) + os.sep


def _prefixes(*paths: str) -> tuple[str, ...]:
    return tuple(str(Path(path).resolve()) + os.sep for path in paths if path)


def _package_dir(module: Any) -> str:
    return str(Path(module.__file__).resolve().parent) + os.sep


class _Origins:
    """Classifies source files by origin, once per file."""

    def __init__(self) -> None:
        paths = sysconfig.get_paths()
        self._beatlog = _BEATLOG_DIR
        self._libraries = _prefixes(
            paths["purelib"], paths["platlib"], *site.getsitepackages(), site.getusersitepackages()
        )
        self._stdlib = _prefixes(paths["stdlib"], paths["platstdlib"])
        self._logging = _package_dir(logging)
        self._known: dict[str, _Origin] = {}

    def of(self, code: CodeType) -> _Origin:
        filename = code.co_filename
        origin = self._known.get(filename)
        if origin is None:
            origin = self._known[filename] = self._classify(filename)
        return origin

    def _classify(self, filename: str) -> _Origin:
        if filename.startswith("<"):  # frozen modules, exec'd strings
            return _Origin.EXEMPT
        path = str(Path(filename).resolve())
        if path.startswith(self._beatlog):
            return _Origin.EXEMPT
        if path.startswith(self._libraries):
            return _Origin.LIBRARY
        if path.startswith(self._stdlib):
            return _Origin.EXEMPT
        return _Origin.USER

    def is_logging(self, code: CodeType) -> bool:
        return code.co_filename.startswith(self._logging)


class _GlobalNumpyGenerator:
    """Notices when numpy's global generator draws, is seeded or is replaced; never,
    where numpy is not installed."""

    def __init__(self) -> None:
        self._legacy: Any = None  # behind np.random.rand & co
        self._mt19937: Any = None
        try:
            import numpy as np  # noqa: PLC0415 - optional: numpy is the arrays extra
        except ImportError:
            pass
        else:
            self._legacy = np.random.mtrand._rand
            self._mt19937 = np.random.MT19937
        self._bit_generator: Any = None
        self._key0: ctypes.c_uint32 | None = None
        self._position: ctypes.c_int | None = None
        self._mark = self._read()

    def moved(self) -> bool:
        """Whether the generator moved since the last call."""
        mark = self._read()
        if mark == self._mark:
            return False
        self._mark = mark
        return True

    def _read(self) -> tuple[object, ...]:
        if self._legacy is None:
            return ()
        bit_generator = self._legacy._bit_generator
        if bit_generator is not self._bit_generator:
            self._attach(bit_generator)
        if self._position is not None and self._key0 is not None:
            # MT19937, numpy's default: its position in place, without copying the state.
            # A draw of a whole key's length regenerates the key, so key[0] changes too.
            return bit_generator, self._position.value, self._key0.value
        return bit_generator, repr(bit_generator.state)

    def _attach(self, bit_generator: Any) -> None:
        self._bit_generator = bit_generator
        self._key0 = self._position = None
        if isinstance(bit_generator, self._mt19937):
            address = bit_generator.ctypes.state_address
            self._key0 = ctypes.c_uint32.from_address(address)
            self._position = ctypes.c_int.from_address(address + _MT19937_POSITION)


def _marked(generator: _GlobalNumpyGenerator | None) -> _GlobalNumpyGenerator:
    """A watcher of numpy's global generator, marked where it stands now: draws between
    updates are the framework's or the test's."""
    if generator is None:
        return _GlobalNumpyGenerator()
    generator.moved()
    return generator


Where = tuple[CodeType, int]


def _site(where: Where) -> str:
    code, line = where
    return f"{code.co_filename}:{line} in {code.co_qualname}"


class LeakWatch:
    """Counts wall-clock reads and global random calls made by code called inside it.

    Enter it around each update of the system under test; calls made directly by the
    frame that enters it, or outside it, are not counted. With ``lines`` off it follows
    no lines (the costliest hook by far): numpy's global generator is then only checked
    on leaving, and :attr:`numpy_moved` says whether it moved inside, so that a second
    replay with ``lines`` on can find where.
    """

    def __init__(self, *, lines: bool = True) -> None:
        self._lines = lines
        self.numpy_moved = False
        """Whether numpy's global generator moved inside the watch (with ``lines`` off)."""
        self._origins = _Origins()
        self._python_calls = _python_calls()
        self._counts: collections.Counter[tuple[str, str, str | None]] = collections.Counter()
        self._numpy: _GlobalNumpyGenerator | None = None
        self._boundary: FrameType | None = None
        self._inside: FrameType | None = None
        self._where: Where | None = None
        self._saved: tuple[Any, Any] = (None, None)

    def findings(self) -> list[Finding]:
        """What was caught so far, in the order first seen."""
        return [
            Finding(call, site, count, via) for (call, site, via), count in self._counts.items()
        ]

    def __enter__(self) -> LeakWatch:
        self._boundary = sys._getframe(1)  # the frame that runs the update
        self._numpy = _marked(self._numpy)
        self._inside = None
        self._where = None
        self._saved = (sys.getprofile(), sys.gettrace())
        if self._lines:
            sys.settrace(self._trace)
        sys.setprofile(self._profile)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        profile, trace = self._saved
        sys.setprofile(profile)
        sys.settrace(trace)
        self._boundary = None
        if not self._lines and self._numpy is not None and self._numpy.moved():
            self.numpy_moved = True

    def _profile(self, frame: FrameType, event: str, arg: Any) -> None:
        if event == "c_call":
            if self._inside is None:
                call = _builtin_call(arg)
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
        if self._origins.of(frame.f_code) is not _Origin.USER:
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
            if frame.f_back is not None:
                self._where = self._nearest(frame.f_back)
        return self._trace_lines

    def _check_numpy(self) -> None:
        assert self._numpy is not None
        if self._numpy.moved() and self._where is not None:
            self._counts["numpy.random", _site(self._where), None] += 1

    def _count(self, call: str, caller: FrameType) -> None:
        if self._origins.is_logging(caller.f_code):
            return
        site, via = self._culprit(caller)
        if site is not None:
            self._counts[call, _site(site), None if via is None else _site(via)] += 1

    def _nearest(self, frame: FrameType | None) -> Where | None:
        """The nearest user frame below the boundary, else the nearest installed package's."""
        site, via = self._culprit(frame)
        return via or site

    def _culprit(self, frame: FrameType | None) -> tuple[Where | None, Where | None]:
        """The line that made the call (the nearest frame of user code or of an installed
        package below the boundary) and, when that is a package's, the first frame of
        user code that led there."""
        site: Where | None = None
        while frame is not None and frame is not self._boundary:
            origin = self._origins.of(frame.f_code)
            if origin is _Origin.USER:
                where = frame.f_code, frame.f_lineno
                return (where, None) if site is None else (site, where)
            if origin is _Origin.LIBRARY and site is None:
                site = frame.f_code, frame.f_lineno
            frame = frame.f_back
        return site, None


def _builtin_call(function: Any) -> str | None:
    """The name of a watched builtin, or None; runs for every builtin call, so it is lean."""
    owner = getattr(function, "__self__", None)
    if owner is None:
        return None
    name: str = function.__name__
    if owner is time:
        return f"time.{name}" if name in _CLOCKS else None
    if owner is random._inst:  # behind random.random & co
        return f"random.{name}"
    if owner is _URANDOM_OWNER:
        return "os.urandom" if name == "urandom" else None
    if isinstance(owner, type) and name in _NOW and issubclass(owner, dt.date):
        return f"{owner.__module__}.{owner.__qualname__}.{name}"
    return None


def _python_calls() -> dict[CodeType, str]:
    """The watched Python functions by code object: methods of ``random.Random``, uuids."""
    calls = {
        member.__code__: f"random.{name}"
        for name, member in vars(random.Random).items()
        if callable(member) and hasattr(member, "__code__")
    }
    calls[uuid.uuid1.__code__] = "uuid.uuid1"
    calls[uuid.uuid4.__code__] = "uuid.uuid4"
    return calls


class LeakScreen:
    """A cheap first look: does code called inside it make any call a :class:`LeakWatch`
    counts, or move numpy's global generator?

    Enter it around each update, like a watch. It profiles with :mod:`cProfile`, whose
    hook is written in C, and afterwards looks for the watched functions among the
    functions called, whoever called them: it cannot say where or how often, nor tell
    the global ``random`` instance's builtin methods from a private instance's. A clean
    screen means a watch would find nothing; anything else is for a watch to look at.
    """

    def __init__(self) -> None:
        self._profiler = cProfile.Profile()
        self._numpy: _GlobalNumpyGenerator | None = None
        self.numpy_moved = False
        """Whether numpy's global generator moved inside the screen."""

    def __enter__(self) -> LeakScreen:
        self._numpy = _marked(self._numpy)
        self._profiler.enable()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self._profiler.disable()
        assert self._numpy is not None
        if self._numpy.moved():
            self.numpy_moved = True

    @property
    def suspicious(self) -> bool:
        """Whether a watched function was called, or numpy's global generator moved."""
        if self.numpy_moved:
            return True
        python_calls = _python_calls()
        builtins = _screened_builtins()
        return any(
            entry.code in builtins if isinstance(entry.code, str) else entry.code in python_calls
            for entry in self._profiler.getstats()
        )

    def findings(self) -> list[Finding]:
        """None: a screen only says whether a watch is needed."""
        return []


@functools.cache
def _screened_builtins() -> frozenset[str]:
    """The labels :mod:`cProfile` gives the watched builtins, learnt by profiling a call
    of each: clocks, the builtin methods behind ``random.random`` and ``getrandbits`` (of
    a private instance: the label is the type's), ``os.urandom``, ``now`` and ``today``."""
    private = random.Random(0)  # noqa: S311 - only its methods' profiler labels are wanted
    calls: list[tuple[Any, tuple[Any, ...]]] = [
        (getattr(time, name), (time.CLOCK_MONOTONIC,) if "clock_gettime" in name else ())
        for name in sorted(_CLOCKS)
        if hasattr(time, name)
    ]
    calls += [(private.random, ()), (private.getrandbits, (1,)), (os.urandom, (1,))]
    calls += [(dt.datetime.now, ()), (dt.datetime.utcnow, ()), (dt.date.today, ())]
    profiler = cProfile.Profile()
    for call, arguments in calls:
        profiler.enable()
        call(*arguments)
        profiler.disable()
    return frozenset(
        entry.code
        for entry in profiler.getstats()
        if isinstance(entry.code, str) and "_lsprof.Profiler" not in entry.code
    )
