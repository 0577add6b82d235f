"""A suite's transition coverage, from its specs: what each DTC's recording exercises,
and what earlier coverage runs saw: the states and transitions each behavior reached,
which catches a state no DTC reaches today (a DTC deleted, a recording replaced).

Like pytest's ``.pytest_cache``, the memory lives in ``.beatlog_cache`` at the project
root (else the suite's folder), which ignores itself in git (:func:`cache_file`,
:func:`read_cached`, :func:`write_cached`, which ``--lf`` shares). Its ``coverage.json``
keeps each system's behaviors apart, names DTCs by their ids, is bounded
(:data:`MAX_STATES`, :data:`MAX_TRANSITIONS`, :data:`MAX_DTCS`) and is checked on
loading: a damaged or foreign file is ignored with a warning. Delete the folder to
forget. A version 1 file, from before systems were told apart, is read too: each
behavior counts for one of its name in any system until a run covers it, and each DTC
name for the suite's DTCs of that name.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any

import msgspec

from beatlog.analysis.coverage import BehaviorCoverage, SuiteCoverage, cover_changes
from beatlog.analysis.recorded import RecordedChanges, read_changes
from beatlog.errors import BeatlogError, LogError, OptionError, RemoteLogError
from beatlog.log.files import irregular_file_problem, project_root, replacing
from beatlog.log.limits import MAX_BEHAVIORS, MAX_NAME_LENGTH, MAX_TEXT_LENGTH
from beatlog.model.behavior import System
from beatlog.project.config import vouched_system
from beatlog.project.usercode import load_system
from beatlog.replay.baseline import TracedStateChange
from beatlog.suite.spec import SPEC_SUFFIX, DtcSpec

__all__ = [
    "CACHE_FOLDER",
    "MAX_DTCS",
    "MAX_STATES",
    "MAX_SYSTEMS",
    "MAX_TRANSITIONS",
    "cache_file",
    "cache_path",
    "read_cached",
    "recall",
    "select_exercising",
    "suite_coverage",
    "write_cached",
]


def suite_coverage(
    specs: Sequence[DtcSpec], recorded: Mapping[str, RecordedChanges] | None = None
) -> SuiteCoverage:
    """The coverage of ``specs``, system by system: the state changes their logs
    recorded (from ``recorded``, by spec id, where their run gathered them), with each
    behavior's first and declared states from a fresh system. A log that cannot be read
    counts nothing: its DTC's verdict says what is wrong."""
    coverage = cover_changes(_dtcs(specs, unreadable=set(), recorded=recorded or {}))
    coverage.labels = {spec.id: spec.label for spec in specs}
    return coverage


def _dtcs(
    specs: Sequence[DtcSpec],
    *,
    unreadable: set[Path],
    systems: bool = True,
    recorded: Mapping[str, RecordedChanges],
) -> Iterator[tuple[str, str, list[TracedStateChange], int, System | None]]:
    """Each readable spec's id and system, the state changes its log recorded and its
    cycles, and a fresh system when ``systems`` (None where none can be built); the
    paths of the specs whose log cannot be read go to ``unreadable``."""
    for spec in specs:
        changes = recorded.get(spec.id)
        if changes is None:
            try:
                with spec.readable_log() as log:
                    changes = read_changes(log)
            except (LogError, RemoteLogError):
                unreadable.add(spec.path)
                continue
        system: System | None = None
        if systems:
            try:
                system = load_system(
                    spec.system
                    or vouched_system(spec.log, changes.reference, project=spec.path.parent)
                )
            except BeatlogError:  # the verdict reports it; coverage counts the log
                system = None
        yield spec.id, spec.system or changes.system, changes.changes, changes.cycles, system


def select_exercising(specs: Sequence[DtcSpec], behavior: str) -> list[DtcSpec]:
    """The specs whose recordings change ``behavior``'s state (no system is built), and
    those whose log cannot be read, so that their verdicts say what is wrong with it.

    :raises beatlog.errors.OptionError: none does and every log could be read.
    """
    unreadable: set[Path] = set()
    coverage = cover_changes(_dtcs(specs, unreadable=unreadable, systems=False, recorded={}))
    names = set(coverage.exercising(behavior))
    if not names and not unreadable:
        changed = dict.fromkeys(cover.behavior for cover in coverage.behaviors if cover.transitions)
        raise OptionError(
            f"no DTC changes the state of behavior {behavior!r}; they change "
            + (", ".join(changed) or "none")
        )
    return [spec for spec in specs if spec.id in names or spec.path in unreadable]


# What earlier runs saw

CACHE_FOLDER = ".beatlog_cache"
MAX_STATES = 256
"""Most states remembered per behavior."""
MAX_TRANSITIONS = 1024
"""Most transitions remembered per behavior."""
MAX_DTCS = 8
"""Most DTC ids remembered per state or transition."""
MAX_SYSTEMS = 64
"""Most systems remembered."""
_MAX_FILE_BYTES = 16 << 20
_EARLIER = ""
"""Where the behaviors a version 1 file remembers go: no system's, so any system's."""
_GITIGNORE = b"# Created by beatlog automatically.\n*\n"
_CACHEDIR_TAG = (
    b"Signature: 8a477f597d28d172789f06886806bc55\n"
    b"# This file is a cache directory tag created by beatlog.\n"
    b"# For information about cache directory tags, see:\n"
    b"#\thttps://bford.info/cachedir/spec.html\n"
)

Name = Annotated[str, msgspec.Meta(max_length=MAX_NAME_LENGTH)]
Text = Annotated[str, msgspec.Meta(max_length=MAX_TEXT_LENGTH)]
Dtcs = Annotated[list[Text], msgspec.Meta(max_length=MAX_DTCS)]


class _Behavior(msgspec.Struct, forbid_unknown_fields=True):
    states: Annotated[dict[Text, Dtcs], msgspec.Meta(max_length=MAX_STATES)]
    transitions: Annotated[list[tuple[Text, Text, Dtcs]], msgspec.Meta(max_length=MAX_TRANSITIONS)]


Behaviors = Annotated[dict[Name, _Behavior], msgspec.Meta(max_length=MAX_BEHAVIORS)]


class _Memory(msgspec.Struct, forbid_unknown_fields=True, tag_field="version", tag=2):
    systems: Annotated[dict[Text, Behaviors], msgspec.Meta(max_length=MAX_SYSTEMS)]


class _MemoryV1(msgspec.Struct, forbid_unknown_fields=True, tag_field="version", tag=1):
    behaviors: Behaviors


def cache_file(suite: Path, name: str) -> Path:
    """The file ``name`` of the cache folder of the suite at ``suite`` (a spec or a
    folder of specs): at its project root, else in its folder."""
    folder = suite if suite.is_dir() else suite.parent
    return (project_root(folder) or folder.resolve()) / CACHE_FOLDER / name


def cache_path(suite: Path) -> Path:
    """The coverage memory of the suite at ``suite`` (a spec or a folder of specs)."""
    return cache_file(suite, "coverage.json")


def read_cached(path: Path, kind: Any, what: str) -> tuple[Any, str | None]:
    """The JSON document of type ``kind`` in the cache file at ``path``, or None with a
    warning where it cannot be read or trusted (too large, damaged, not ``what``)."""
    if not path.exists():
        return None, None
    problem = irregular_file_problem(path)
    if problem is None and path.stat().st_size > _MAX_FILE_BYTES:
        problem = f"is larger than {_MAX_FILE_BYTES} bytes"
    if problem is None:
        try:
            return msgspec.json.decode(path.read_bytes(), type=kind), None
        except OSError as exc:
            problem = f"cannot read: {exc.strerror or exc}"
        except (msgspec.DecodeError, RecursionError) as exc:
            problem = f"not {what} ({exc})"
    return None, f"{path}: {problem}; ignored, and replaced by what this run saw"


def write_cached(path: Path, document: object) -> None:
    """Write a JSON document to the cache file at ``path``, whole or not at all (else an
    :class:`OSError`); the cache folder, made when missing, ignores itself in git and
    tells backup tools it is a cache."""
    folder = path.parent
    if not folder.is_dir():
        folder.mkdir(parents=True)
        (folder / ".gitignore").write_bytes(_GITIGNORE)
        (folder / "CACHEDIR.TAG").write_bytes(_CACHEDIR_TAG)
    with replacing(path) as file:
        file.write(msgspec.json.format(msgspec.json.encode(document)) + b"\n")


def recall(coverage: SuiteCoverage, path: Path, suite: Mapping[str, str]) -> str | None:
    """Mark on ``coverage`` what earlier runs saw (from the file at ``path``), then
    remember what this run saw too. A file that cannot be read or trusted is ignored,
    one that cannot be written left as it is; either way a warning says why.

    Only what concerns this run is marked: the behaviors its DTCs have, and of those
    the states and transitions that a DTC reached before which ran now, or which the
    suite no longer holds (deleted, renamed). ``suite`` maps every DTC of the suite,
    run or not, from its id to its name: a DTC left out by ``-k``, ``--behavior`` or
    ``--shard`` did not lose what it reached. Everything stays remembered."""
    earlier, warning = read_cached(path, _Memory | _MemoryV1, "a beatlog coverage memory")
    if not isinstance(earlier, _Memory):
        earlier = _Memory(systems={}) if earlier is None else _upgraded(earlier, suite)
    ran = set(coverage.dtcs)

    def concerns(dtcs: Sequence[str]) -> bool:
        return any(dtc in ran or dtc not in suite for dtc in dtcs)

    for cover in coverage.behaviors:
        remembered = _remembered(earlier, cover)
        if remembered is None:
            continue
        cover.states_before = {
            state: tuple(dtcs) for state, dtcs in remembered.states.items() if concerns(dtcs)
        }
        cover.transitions_before = {
            (before, after): tuple(dtcs)
            for before, after, dtcs in remembered.transitions
            if concerns(dtcs)
        }
    _name_remembered(coverage, suite)
    try:
        write_cached(path, _merged(earlier, coverage))
    except OSError as exc:
        warning = warning or f"{path}: cannot write: {exc.strerror or exc}; nothing remembered"
    return warning


def _name_remembered(coverage: SuiteCoverage, suite: Mapping[str, str]) -> None:
    """Name the DTCs that earlier runs saw, and this one did not run, as the run's are
    named: by name where no other DTC of the suite has it, else by id."""
    names = Counter(suite.values())
    for cover in coverage.behaviors:
        for dtcs in (*cover.states_before.values(), *cover.transitions_before.values()):
            for dtc in dtcs:
                if dtc in coverage.labels:
                    continue
                name = suite.get(dtc) or dtc.partition(f"{SPEC_SUFFIX}::")[2] or dtc
                shared = names[name] > (dtc in suite)
                coverage.labels[dtc] = dtc if shared else name


def _upgraded(memory: _MemoryV1, suite: Mapping[str, str]) -> _Memory:
    """A version 1 memory as version 2 does it: its behaviors no system's, and each DTC
    by the ids of the suite's DTCs of its name (the name itself where none has it)."""
    ids: dict[str, list[str]] = {}
    for dtc, name in suite.items():
        ids.setdefault(name, []).append(dtc)

    def named(dtcs: list[str]) -> list[str]:
        return list(dict.fromkeys(i for dtc in dtcs for i in ids.get(dtc, [dtc])))[:MAX_DTCS]

    behaviors = {
        name: _Behavior(
            states={state: named(dtcs) for state, dtcs in behavior.states.items()},
            transitions=[(start, end, named(dtcs)) for start, end, dtcs in behavior.transitions],
        )
        for name, behavior in memory.behaviors.items()
    }
    return _Memory(systems={_EARLIER: behaviors} if behaviors else {})


def _remembered(memory: _Memory, cover: BehaviorCoverage) -> _Behavior | None:
    """What ``memory`` remembers of a behavior: of its system, and from a version 1 file."""
    found = [
        behaviors[cover.behavior]
        for system in (cover.system, _EARLIER)
        if cover.behavior in (behaviors := memory.systems.get(system, {}))
    ]
    if not found:
        return None
    states: dict[str, list[str]] = {}
    edges: dict[tuple[str, str], list[str]] = {}
    for behavior in found:
        for state, dtcs in behavior.states.items():
            states[state] = _names(states.get(state, []), dtcs)
        for start, end, dtcs in behavior.transitions:
            edges[start, end] = _names(edges.get((start, end), []), dtcs)
    return _Behavior(states, [(start, end, dtcs) for (start, end), dtcs in edges.items()])


def _merged(earlier: _Memory, coverage: SuiteCoverage) -> _Memory:
    """What earlier runs and this one saw, within the bounds; what a version 1 file
    remembered of a behavior this run covers goes to the behavior's system."""
    systems = {system: dict(behaviors) for system, behaviors in earlier.systems.items()}
    moved: set[str] = set()
    for cover in coverage.behaviors:
        if len(cover.system) > MAX_TEXT_LENGTH or len(cover.behavior) > MAX_NAME_LENGTH:
            continue
        behaviors = systems.setdefault(cover.system, {})
        if cover.behavior not in behaviors and len(behaviors) >= MAX_BEHAVIORS:
            continue
        before = _remembered(earlier, cover) or _Behavior(states={}, transitions=[])
        behaviors[cover.behavior] = _with(before, cover)
        moved.add(cover.behavior)
    earliest = {
        name: behavior for name, behavior in systems.pop(_EARLIER, {}).items() if name not in moved
    }
    if earliest:
        systems[_EARLIER] = earliest
    kept = list(systems)[:MAX_SYSTEMS]
    return _Memory(systems={system: systems[system] for system in kept})


def _with(before: _Behavior, cover: BehaviorCoverage) -> _Behavior:
    """What was remembered of a behavior and what this run saw of it, within the bounds."""
    states = {state: list(dtcs) for state, dtcs in before.states.items()}
    edges = {(start, end): list(dtcs) for start, end, dtcs in before.transitions}
    for state, seen in cover.states.items():
        if len(state) > MAX_TEXT_LENGTH:
            continue
        if state in states or len(states) < MAX_STATES:
            states[state] = _names(sorted(seen.dtcs), states.get(state, []))
    for edge, seen in cover.transitions.items():
        if max(map(len, edge)) > MAX_TEXT_LENGTH:
            continue
        if edge in edges or len(edges) < MAX_TRANSITIONS:
            edges[edge] = _names(sorted(seen.dtcs), edges.get(edge, []))
    return _Behavior(states, [(start, end, dtcs) for (start, end), dtcs in edges.items()])


def _names(first: Sequence[str], then: Sequence[str]) -> list[str]:
    """The DTCs that reached something: ``first``, then ``then``, bounded."""
    names = [name for name in (*first, *then) if len(name) <= MAX_TEXT_LENGTH]
    return list(dict.fromkeys(names))[:MAX_DTCS]
