"""What earlier coverage runs saw: the states and transitions each behavior reached.

A state reached by no DTC today may only be one that no behavior declares; remembering
what earlier runs saw catches it anyway (a DTC deleted, a recording replaced). Like
pytest's ``.pytest_cache``, the memory lives in a cache folder at the project root
(the nearest ``pyproject.toml``, else the suite's folder), ``.beatlog_cache``, which
ignores itself in git. Its one file, ``coverage.json``, is small and bounded (at most
:data:`MAX_STATES` states and :data:`MAX_TRANSITIONS` transitions per behavior, each
with up to :data:`MAX_DTCS` DTC names) and is checked on loading: a damaged or foreign
file is ignored with a warning, never a crash. Delete the folder to forget.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

import msgspec

from beatlog.analysis.coverage import SuiteCoverage
from beatlog.files import irregular_file_problem, project_root, replacing
from beatlog.log.limits import MAX_BEHAVIORS, MAX_NAME_LENGTH, MAX_TEXT_LENGTH

__all__ = [
    "CACHE_FOLDER",
    "MAX_DTCS",
    "MAX_STATES",
    "MAX_TRANSITIONS",
    "Recall",
    "cache_path",
    "recall",
]

CACHE_FOLDER = ".beatlog_cache"
MAX_STATES = 256
"""Most states remembered per behavior."""
MAX_TRANSITIONS = 1024
"""Most transitions remembered per behavior."""
MAX_DTCS = 8
"""Most DTC names remembered per state or transition."""
_MAX_FILE_BYTES = 16 << 20
_VERSION: Literal[1] = 1
_GITIGNORE = b"# Created by beatlog automatically.\n*\n"
_CACHEDIR_TAG = (
    b"Signature: 8a477f597d28d172789f06886806bc55\n"
    b"# This file is a cache directory tag created by beatlog.\n"
    b"# For information about cache directory tags, see:\n"
    b"#\thttps://bford.info/cachedir/spec.html\n"
)

Name = Annotated[str, msgspec.Meta(max_length=MAX_NAME_LENGTH)]
State = Annotated[str, msgspec.Meta(max_length=MAX_TEXT_LENGTH)]
Dtcs = Annotated[list[Name], msgspec.Meta(max_length=MAX_DTCS)]
Transition = tuple[State, State, Dtcs]


class _Behavior(msgspec.Struct, forbid_unknown_fields=True):
    states: Annotated[dict[State, Dtcs], msgspec.Meta(max_length=MAX_STATES)]
    transitions: Annotated[
        list[tuple[State, State, Dtcs]], msgspec.Meta(max_length=MAX_TRANSITIONS)
    ]


class _Memory(msgspec.Struct, forbid_unknown_fields=True):
    version: Literal[1]
    behaviors: Annotated[dict[Name, _Behavior], msgspec.Meta(max_length=MAX_BEHAVIORS)]


@dataclass(frozen=True)
class Recall:
    """What remembering did: the cache file, and a warning when it could not be used."""

    path: Path
    warning: str | None = None


def cache_path(suite: Path) -> Path:
    """The coverage memory of the suite at ``suite`` (a spec or a folder of specs)."""
    folder = suite if suite.is_dir() else suite.parent
    return (project_root(folder) or folder.resolve()) / CACHE_FOLDER / "coverage.json"


def recall(coverage: SuiteCoverage, path: Path, suite: Collection[str]) -> Recall:
    """Mark on ``coverage`` what earlier runs saw (from the file at ``path``), then
    remember what this run saw too. A file that cannot be read or trusted is ignored,
    one that cannot be written left as it is; either way the warning says why.

    Only what concerns this run is marked: the behaviors its DTCs have, and of those
    the states and transitions that a DTC reached before which ran now, or which the
    suite no longer holds (deleted, renamed). ``suite`` names every DTC of the suite,
    run or not: a DTC left out by ``-k``, ``--behavior`` or ``--shard`` did not lose
    what it reached. Everything stays remembered."""
    earlier, warning = _load(path)
    ran = set(coverage.dtcs)
    known = set(suite)

    def concerns(dtcs: Sequence[str]) -> bool:
        return any(dtc in ran or dtc not in known for dtc in dtcs)

    for name, behavior in earlier.behaviors.items():
        cover = coverage.behaviors.get(name)
        if cover is None:
            continue
        cover.states_before = {
            state: tuple(dtcs) for state, dtcs in behavior.states.items() if concerns(dtcs)
        }
        cover.transitions_before = {
            (before, after): tuple(dtcs)
            for before, after, dtcs in behavior.transitions
            if concerns(dtcs)
        }
    try:
        _save(path, _merged(earlier, coverage))
    except OSError as exc:
        warning = warning or f"{path}: cannot write: {exc.strerror or exc}; nothing remembered"
    return Recall(path, warning)


def _load(path: Path) -> tuple[_Memory, str | None]:
    empty = _Memory(version=_VERSION, behaviors={})
    if not path.exists():
        return empty, None
    problem = irregular_file_problem(path)
    if problem is None and path.stat().st_size > _MAX_FILE_BYTES:
        problem = f"is larger than {_MAX_FILE_BYTES} bytes"
    if problem is None:
        try:
            return msgspec.json.decode(path.read_bytes(), type=_Memory), None
        except OSError as exc:
            problem = f"cannot read: {exc.strerror or exc}"
        except (msgspec.DecodeError, RecursionError) as exc:
            problem = f"not a beatlog coverage memory ({exc})"
    return empty, f"{path}: {problem}; ignored, and replaced by what this run saw"


def _merged(earlier: _Memory, coverage: SuiteCoverage) -> _Memory:
    """What earlier runs and this one saw, within the bounds."""
    behaviors: dict[str, _Behavior] = {}
    names = list(dict.fromkeys([*earlier.behaviors, *coverage.behaviors]))
    for name in names[:MAX_BEHAVIORS]:
        before = earlier.behaviors.get(name, _Behavior(states={}, transitions=[]))
        states = {state: list(dtcs) for state, dtcs in before.states.items()}
        edges = {(start, end): list(dtcs) for start, end, dtcs in before.transitions}
        cover = coverage.behaviors.get(name)
        for state, seen in {} if cover is None else cover.states.items():
            if len(state) > MAX_TEXT_LENGTH:
                continue
            if state in states or len(states) < MAX_STATES:
                states[state] = _names(states.get(state, []), seen.dtcs)
        for edge, seen in {} if cover is None else cover.transitions.items():
            if max(map(len, edge)) > MAX_TEXT_LENGTH:
                continue
            if edge in edges or len(edges) < MAX_TRANSITIONS:
                edges[edge] = _names(edges.get(edge, []), seen.dtcs)
        transitions = [(start, end, dtcs) for (start, end), dtcs in edges.items()]
        behaviors[name] = _Behavior(states=states, transitions=transitions)
    return _Memory(version=_VERSION, behaviors=behaviors)


def _names(earlier: list[str], now: set[str]) -> list[str]:
    """The DTCs that reached something: this run's first, then earlier ones, bounded."""
    names = sorted(name for name in now if len(name) <= MAX_NAME_LENGTH)
    return list(dict.fromkeys([*names, *earlier]))[:MAX_DTCS]


def _save(path: Path, memory: _Memory) -> None:
    folder = path.parent
    if not folder.is_dir():
        folder.mkdir(parents=True)
        (folder / ".gitignore").write_bytes(_GITIGNORE)
        (folder / "CACHEDIR.TAG").write_bytes(_CACHEDIR_TAG)
    with replacing(path) as file:
        file.write(msgspec.json.format(msgspec.json.encode(memory)) + b"\n")
