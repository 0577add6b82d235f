"""What a leak watch watches: the calls that read the wall clock or a global random
number generator, numpy's global generator, and the numpy generators a system's set-up
seeded from the OS (:class:`PrivateGenerator`); the list, and what goes unseen, is in
the how-to guide "Audit determinism".
"""

from __future__ import annotations

import collections
import cProfile
import ctypes
import datetime as dt
import functools
import gc
import os
import random
import time
import uuid
import warnings
from collections.abc import Mapping
from types import CodeType, ModuleType
from typing import Any

__all__ = [
    "ENTROPY_READ",
    "SEARCHED",
    "GlobalNumpyGenerator",
    "PrivateGenerator",
    "builtin_call",
    "python_calls",
    "screened_builtins",
]

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
ENTROPY_READ = random.SystemRandom.getrandbits.__code__
"""What numpy's ``SeedSequence`` calls for the entropy of a generator made without a
seed (``secrets.randbits``); it returns the entropy the generator keeps."""
SEARCHED = 200_000
"""The most objects searched from a system for its unseeded generators."""


class _Marked:
    """A generator watched by a mark of its state: :meth:`moved` says whether the mark
    changed since the last call."""

    name: str
    """How findings name it."""
    _mark: object

    def _read(self) -> object:
        raise NotImplementedError

    def moved(self) -> bool:
        """Whether the generator moved since the last call."""
        mark = self._read()
        if mark == self._mark:
            return False
        self._mark = mark
        return True


class GlobalNumpyGenerator(_Marked):
    """Notices when numpy's global generator draws, is seeded or is replaced; never,
    where numpy is not installed."""

    name = "numpy.random"

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

    def _read(self) -> tuple[object, ...]:
        if self._legacy is None:
            return ()
        bit_generator = self._legacy._bit_generator
        if bit_generator is not self._bit_generator:
            self._attach(bit_generator)
        if self._position is not None and self._key0 is not None:
            # MT19937, numpy's default: its position in place, without copying the state.
            # A draw of a whole key's length regenerates the key, so key[0] changes too.
            # Read on every traced line: a watch of 50 updates of 200 lines each takes
            # 0.14 s this way, 4.2 s reading ``state`` (0.7 against 180 us a read);
            # tests/project/test_watched.py pins it to the whole state it stands for.
            return bit_generator, self._position.value, self._key0.value
        return bit_generator, repr(bit_generator.state)

    def _attach(self, bit_generator: Any) -> None:
        self._bit_generator = bit_generator
        self._key0 = self._position = None
        if isinstance(bit_generator, self._mt19937):
            address = bit_generator.ctypes.state_address
            self._key0 = ctypes.c_uint32.from_address(address)
            self._position = ctypes.c_int.from_address(address + _MT19937_POSITION)


def builtin_call(function: Any) -> str | None:
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


def python_calls() -> dict[CodeType, str]:
    """The watched Python functions by code object: methods of ``random.Random``, uuids."""
    calls = {
        member.__code__: f"random.{name}"
        for name, member in vars(random.Random).items()
        if callable(member) and hasattr(member, "__code__")
    }
    calls[uuid.uuid1.__code__] = "uuid.uuid1"
    calls[uuid.uuid4.__code__] = "uuid.uuid4"
    return calls


@functools.cache
def screened_builtins() -> frozenset[str]:
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
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # utcnow, from Python 3.12
        for call, arguments in calls:
            profiler.enable()
            try:
                call(*arguments)
            finally:
                profiler.disable()
    return frozenset(
        entry.code
        for entry in profiler.getstats()
        if isinstance(entry.code, str) and "_lsprof.Profiler" not in entry.code
    )


class PrivateGenerator(_Marked):
    """A numpy generator of the system's own that its set-up seeded from the OS: it
    notices when the generator draws, as :class:`GlobalNumpyGenerator` does for numpy's
    global one, and is named by its type and the line that made it."""

    def __init__(self, generator: Any, made: str) -> None:
        self._bit_generator = _bit_generator(generator)
        self.name = f"unseeded numpy.random.{type(generator).__name__} made at {made}"
        """How findings name it, e.g. ``unseeded numpy.random.Generator made at
        driver.py:12 in Follow.__init__``."""
        self._mark = self._read()

    def _read(self) -> str:
        return repr(self._bit_generator.state)

    @staticmethod
    def found(system: object, made: Mapping[int, str]) -> list[PrivateGenerator]:
        """The numpy generators reachable from ``system`` (not through modules or
        classes) whose entropy is a key of ``made``, the entropies read while it was
        built by the line that read each: the generators its set-up made without a seed.
        The search goes breadth first, so what the system holds is seen before what
        its functions' globals reach, however many modules the process has loaded."""
        try:
            import numpy as np  # noqa: PLC0415 - optional: numpy is the arrays extra
        except ImportError:
            return []
        kinds = (np.random.Generator, np.random.RandomState)
        legacy = np.random.mtrand._rand  # numpy's global generator: watched as such
        found: list[PrivateGenerator] = []
        seen: set[int] = set()
        waiting: collections.deque[object] = collections.deque([system])
        while waiting and len(seen) < SEARCHED:
            item = waiting.popleft()
            if id(item) in seen or isinstance(item, _NOT_SEARCHED):
                continue
            seen.add(id(item))
            if isinstance(item, kinds) and item is not legacy:
                entropy = getattr(_bit_generator(item).seed_seq, "entropy", None)
                if isinstance(entropy, int) and entropy in made:
                    found.append(PrivateGenerator(item, made[entropy]))
                continue
            waiting.extend(gc.get_referents(item))
        return found


_NOT_SEARCHED = (ModuleType, type, int, float, complex, str, bytes)
"""What the search for a system's generators never looks into: modules and classes (a
generator the set-up made lives in what was built), and values that hold no others."""


def _bit_generator(generator: Any) -> Any:
    """A numpy ``Generator``'s or ``RandomState``'s bit generator."""
    return getattr(generator, "bit_generator", None) or generator._bit_generator
