"""Mutation testing: single-point mutants of the dog's behaviors and perception, each
replayed against the dog's DTC suite, to measure how much of a change the suite catches.

The mutator is a small one on the standard library's ``ast``; mutmut and cosmic-ray do
far more (their own runners, caches and databases) than one module and one suite need.
Each mutant changes one thing, named ``file:line:col`` and a short description:

- an operator swapped: ``<``↔``<=``, ``>``↔``>=``, ``==``↔``!=``, ``+``↔``-``, ``*``↔``/``
  (in augmented assignments too), ``and``↔``or``;
- a number changed: a float times 1.1, an int (and 0.0) plus 1;
- an ``if`` condition (statement or expression) negated; ``True``↔``False``.

Annotations, decorators and class bases are left alone (declarations, not behavior).
The ``behaviors`` group is the dog's behavior code: ``behaviors.py`` without the robot
state and the deliberate changes (``CHANGES``, ``changed_system``) the suite is not for.
The ``perception`` group is ``perception.py`` and the robot state's defaults, which are
the perception's first state.

Each mutant runs in a fresh process: a child forked for it alone by a worker process
(this script with ``--worker``) that has imported beatlog but none of the dog's code. In
the child a finder on ``sys.meta_path`` imports the mutated source, written to a
temporary file, under the module's real name, so mutants never meet. The child loads
every spec of the suite with ``load_spec`` and replays it with ``run_spec``; the mutant
is *killed* when a DTC fails or errors (or the child dies or runs past its time).
Perception is replayed only where a spec names it and its log holds samples, so on a
suite without samples no perception mutant can be killed.

A surviving mutant passed every DTC: replay gave the recorded state changes, outputs and
random numbers bit for bit (the dog's specs allow no differences). A second fresh child
then replays the suite with the *original* module instrumented at the mutated spot (weak
mutation): each time the spot is evaluated, the original and the mutated value are both
computed from the same operand values (each operand evaluated once), the original is
used, and the child counts evaluations and differences (another type, or unequal).
Operators are compared at the operation itself, a number at the comparison or arithmetic
it is an operand of (else at the number); a negated condition or a swapped
``True``/``False`` always differs.
Survivors are then reported as:

- *survived*: the mutated spot gave another value at least once, yet no DTC noticed;
- *survived, possibly equivalent*: it was evaluated and never gave another value on the
  suite's own recorded robot states, so the suite has no input that tells them apart
  (it may still differ on other inputs: these are reported, never discarded);
- *survived, not reached*: the suite never evaluated the mutated spot.

Run it as ``python examples/bench/bench_mutation.py [--jobs N] [--limit N] [--only GROUP]
[--suite DIR] [--json FILE]``; 368 mutants took 4.5 to 7.5 minutes with ``--jobs 2``
on a busy 2-core machine.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import copy
import importlib.abc
import importlib.util
import json
import math
import os
import queue
import select
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from enum import StrEnum
from importlib.machinery import ModuleSpec
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple, TypeVar, cast

from rich.console import Console
from rich.progress import Progress
from rich.table import Table

PROBE = "__mutation_probe__"
"""The global through which an instrumented module reports what its mutated spot did."""
DRAWS = frozenset({"random", "uniform", "gauss", "randint", "choice"})
"""The random source's draws: a number in their arguments is a draw parameter."""
SWAPS: dict[type[ast.AST], type[ast.AST]] = {
    ast.Lt: ast.LtE,
    ast.LtE: ast.Lt,
    ast.Gt: ast.GtE,
    ast.GtE: ast.Gt,
    ast.Eq: ast.NotEq,
    ast.NotEq: ast.Eq,
    ast.Add: ast.Sub,
    ast.Sub: ast.Add,
    ast.Mult: ast.Div,
    ast.Div: ast.Mult,
    ast.And: ast.Or,
    ast.Or: ast.And,
}
SYMBOLS: dict[type[ast.AST], str] = {
    ast.Lt: "<",
    ast.LtE: "<=",
    ast.Gt: ">",
    ast.GtE: ">=",
    ast.Eq: "==",
    ast.NotEq: "!=",
    ast.Add: "+",
    ast.Sub: "-",
    ast.Mult: "*",
    ast.Div: "/",
    ast.And: "and",
    ast.Or: "or",
}


Op = TypeVar("Op", bound=ast.AST)


class Target(NamedTuple):
    """A module to mutate: which of its top-level definitions, in which group."""

    group: str
    module: str
    path: Path
    only: frozenset[str] | None = None
    """The top-level names to mutate; None for all but ``skip``."""
    skip: frozenset[str] = frozenset()


class Kind(StrEnum):
    """What a mutant changes."""

    COMPARE = "compare"
    """One operator of a comparison."""
    BINARY = "binary"
    """An arithmetic operator."""
    AUGMENTED = "augmented"
    """The operator of an augmented assignment (``+=``)."""
    BOOLEAN = "boolean"
    """``and`` or ``or``."""
    CONDITION = "condition"
    """An ``if`` condition, negated."""
    NUMBER = "number"
    """A number literal."""
    TRUTH = "truth"
    """``True`` or ``False``."""


class Outcome(StrEnum):
    """How a mutant fared against the suite."""

    KILLED = "killed"
    """A DTC failed or errored, or the worker died or ran out of time."""
    SURVIVED = "survived"
    """Every DTC passed, though the mutated spot gave another value."""
    POSSIBLY_EQUIVALENT = "survived, possibly equivalent"
    """Every DTC passed and the mutated spot never gave another value on the suite."""
    NOT_REACHED = "survived, not reached"
    """Every DTC passed and the suite never evaluated the mutated spot."""


@dataclass(frozen=True)
class Mutant:
    """One single-point change to a target's source."""

    group: str
    module: str
    path: Path
    site: int
    """The changed node's position in ``ast.walk`` order of the parsed source."""
    kind: Kind
    operand: int
    """Which operator of a comparison; 0 for the other kinds."""
    line: int
    col: int
    description: str
    code: str
    """The source line, for reading the survivor list."""
    draw_parameter: bool
    """A number written in the arguments of a random draw."""

    @property
    def where(self) -> str:
        return f"{self.path.name}:{self.line}:{self.col}"


@dataclass(frozen=True)
class Result:
    """A mutant's outcome, the DTC that killed it and why, and what the probe saw."""

    mutant: Mutant
    outcome: Outcome
    killed_by: str = ""
    reason: str = ""
    evaluations: int = 0
    differences: int = 0


def mutants(target: Target) -> list[Mutant]:
    """Every single-point mutant of the target, in source order."""
    source = target.path.read_text(encoding="utf-8")
    tree = ast.parse(source)
    lines = source.splitlines()
    sites = {id(node): index for index, node in enumerate(ast.walk(tree))}
    found: list[Mutant] = []
    for node, draw in _mutable_nodes(tree, target):
        for kind, operand, description in _mutations(node):
            line, col = getattr(node, "lineno", 0), getattr(node, "col_offset", -1) + 1
            found.append(
                Mutant(
                    group=target.group,
                    module=target.module,
                    path=target.path,
                    site=sites[id(node)],
                    kind=kind,
                    operand=operand,
                    line=line,
                    col=col,
                    description=description,
                    code=lines[line - 1].strip(),
                    draw_parameter=draw and kind is Kind.NUMBER,
                )
            )
    return sorted(found, key=lambda mutant: (mutant.line, mutant.col, mutant.site))


def _mutable_nodes(tree: ast.Module, target: Target) -> Iterator[tuple[ast.AST, bool]]:
    """The nodes of the chosen definitions, outside annotations and declarations, each
    with whether it lies in the arguments of a random draw."""

    def visit(node: ast.AST, draw: bool) -> Iterator[tuple[ast.AST, bool]]:
        yield node, draw
        for name, value in ast.iter_fields(node):
            if name in {"annotation", "returns", "decorator_list", "bases", "keywords"} and (
                not isinstance(node, ast.Call)
            ):
                continue
            in_draw = draw or (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in DRAWS
                and name in {"args", "keywords"}
            )
            for child in value if isinstance(value, list) else [value]:
                if isinstance(child, ast.AST):
                    yield from visit(child, in_draw)

    for statement in tree.body:
        names = _defined_names(statement)
        chosen = target.only is None or bool(names & target.only)
        if names and chosen and not names & target.skip:
            yield from visit(statement, False)


def _defined_names(statement: ast.stmt) -> set[str]:
    if isinstance(statement, ast.FunctionDef | ast.ClassDef):
        return {statement.name}
    if isinstance(statement, ast.Assign):
        return {target.id for target in statement.targets if isinstance(target, ast.Name)}
    if isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name):
        return {statement.target.id}
    return set()


def _mutations(node: ast.AST) -> Iterator[tuple[Kind, int, str]]:
    if isinstance(node, ast.Compare):
        for index, op in enumerate(node.ops):
            if type(op) in SWAPS:
                yield Kind.COMPARE, index, _swap_text(op)
    elif isinstance(node, ast.BinOp) and type(node.op) in SWAPS:
        yield Kind.BINARY, 0, _swap_text(node.op)
    elif isinstance(node, ast.AugAssign) and type(node.op) in SWAPS:
        yield Kind.AUGMENTED, 0, _swap_text(node.op, suffix="=")
    elif isinstance(node, ast.BoolOp):
        yield Kind.BOOLEAN, 0, _swap_text(node.op)
    elif isinstance(node, ast.If | ast.IfExp):
        yield Kind.CONDITION, 0, f"negate `{ast.unparse(node.test)}`"
    elif isinstance(node, ast.Constant) and isinstance(node.value, bool):
        yield Kind.TRUTH, 0, f"{node.value} → {not node.value}"
    elif isinstance(node, ast.Constant) and isinstance(node.value, int | float):
        yield Kind.NUMBER, 0, f"{node.value:.12g} → {_changed_number(node.value):.12g}"


def _swap_text(op: ast.AST, suffix: str = "") -> str:
    return f"`{SYMBOLS[type(op)]}{suffix}` → `{SYMBOLS[SWAPS[type(op)]]}{suffix}`"


def _changed_number(value: float) -> float:
    if isinstance(value, int) or value == 0.0:
        return value + 1
    return value * 1.1


def mutated_source(mutant: Mutant) -> str:
    """The target's source with the mutant's one change."""
    tree = ast.parse(mutant.path.read_text(encoding="utf-8"))
    node = list(ast.walk(tree))[mutant.site]
    _apply(node, mutant)
    return ast.unparse(tree)


def _apply(node: ast.AST, mutant: Mutant) -> None:
    if isinstance(node, ast.Compare):
        node.ops[mutant.operand] = _swapped(node.ops[mutant.operand])
    elif isinstance(node, ast.BinOp | ast.AugAssign):
        node.op = _swapped(node.op)
    elif isinstance(node, ast.BoolOp):
        node.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
    elif isinstance(node, ast.If | ast.IfExp):
        node.test = ast.UnaryOp(op=ast.Not(), operand=node.test)
    elif isinstance(node, ast.Constant) and isinstance(node.value, bool):
        node.value = not node.value
    elif isinstance(node, ast.Constant) and isinstance(node.value, int | float):
        node.value = _changed_number(node.value)


def _swapped(op: Op) -> Op:
    return cast(Op, SWAPS[type(op)]())


def instrumented_source(mutant: Mutant) -> str:
    """The *original* source with the mutated spot computed both ways and reported to
    the probe; the original value is always the one used."""
    tree = ast.parse(mutant.path.read_text(encoding="utf-8"))
    nodes = list(ast.walk(tree))
    parents = {id(child): node for node in nodes for child in ast.iter_child_nodes(node)}
    node = nodes[mutant.site]
    if isinstance(node, ast.AugAssign):
        # x op= v  →  x = probe.operation(original, mutated, x, v): same for numbers
        load = copy.deepcopy(node.target)
        load.ctx = ast.Load()
        value = _operation(node, mutant, [load, node.value])
        _replace(parents[id(node)], node, ast.Assign(targets=[node.target], value=value))
    elif isinstance(node, ast.If | ast.IfExp):
        node.test = _call("branch", [node.test])
    elif isinstance(node, ast.BoolOp):
        thunks = [ast.Lambda(args=_arguments([]), body=value) for value in node.values]
        flag = ast.Constant(isinstance(node.op, ast.And))
        _replace(parents[id(node)], node, _call("boolean", [flag, *thunks]))
    elif isinstance(node, ast.Compare | ast.BinOp):
        _replace(parents[id(node)], node, _operation(node, mutant, _operands(node)))
    else:
        parent = parents[id(node)]
        if isinstance(parent, ast.BinOp) or (
            isinstance(parent, ast.Compare) and len(parent.ops) == 1
        ):
            spot = _operation(parent, mutant, _operands(parent), changed=node)
            _replace(parents[id(parent)], parent, spot)
        else:
            assert isinstance(node, ast.Constant)
            changed = copy.deepcopy(node)
            _apply(changed, mutant)
            _replace(parent, node, _call("value", [node, changed]))
    return ast.unparse(ast.fix_missing_locations(tree))


def _operands(node: ast.Compare | ast.BinOp) -> list[ast.expr]:
    if isinstance(node, ast.BinOp):
        return [node.left, node.right]
    return [node.left, *node.comparators]


def _operation(
    node: ast.Compare | ast.BinOp | ast.AugAssign,
    mutant: Mutant,
    operands: Sequence[ast.expr],
    changed: ast.AST | None = None,
) -> ast.Call:
    """``probe.operation(original, mutated, *operands)``: two lambdas of the operand
    values, the mutated one with the operator swapped or the number ``changed``."""
    names = [f"_operand{index}" for index in range(len(operands))]
    params: list[ast.expr] = [ast.Name(name, ast.Load()) for name in names]
    if isinstance(node, ast.AugAssign):
        original: ast.expr = ast.BinOp(params[0], node.op, params[1])
        mutated: ast.expr = ast.BinOp(params[0], _swapped(node.op), params[1])
    else:
        shape = copy.copy(node)
        if isinstance(shape, ast.BinOp):
            shape.left, shape.right = params
        else:
            shape.left, *shape.comparators = params
            shape.ops = list(shape.ops)
        original = copy.deepcopy(shape)
        mutated = copy.deepcopy(shape)
        if changed is None:
            _apply(mutated, mutant)
        else:
            number = copy.deepcopy(changed)
            _apply(number, mutant)
            _replace(mutated, _operands(mutated)[_operands(node).index(changed)], number)  # type: ignore[arg-type]
    lambdas = [ast.Lambda(args=_arguments(names), body=body) for body in (original, mutated)]
    return _call("operation", [*lambdas, *operands])


def _arguments(names: Sequence[str]) -> ast.arguments:
    return ast.arguments(
        posonlyargs=[],
        args=[ast.arg(name) for name in names],
        kwonlyargs=[],
        kw_defaults=[],
        defaults=[],
    )


def _call(method: str, args: Sequence[ast.expr]) -> ast.Call:
    function = ast.Attribute(ast.Name(PROBE, ast.Load()), method, ast.Load())
    return ast.Call(func=function, args=list(args), keywords=[])


def _replace(parent: ast.AST, old: ast.AST, new: ast.AST) -> None:
    for name, value in ast.iter_fields(parent):
        if value is old:
            setattr(parent, name, new)
            return
        if isinstance(value, list) and any(item is old for item in value):
            value[[item is old for item in value].index(True)] = new
            return
    raise ValueError(f"{ast.dump(old)} is not a child of {ast.dump(parent)}")


class Probe:
    """What an instrumented module's mutated spot did: evaluations and differences."""

    def __init__(self) -> None:
        self.evaluations = 0
        self.differences = 0

    def _saw(self, original: object, mutated: object) -> None:
        self.evaluations += 1
        same = type(original) is type(mutated) and bool(original == mutated)
        self.differences += not same

    def operation(
        self, original: Callable[..., Any], mutated: Callable[..., Any], *operands: Any
    ) -> Any:
        value = original(*operands)
        try:
            other = mutated(*operands)
        except Exception as exc:  # the mutant would have raised here: a difference
            other = exc
        self._saw(value, other)
        return value

    def boolean(self, conjunction: bool, *operands: Callable[[], Any]) -> Any:
        """``and`` (or ``or``) of the operands as Python evaluates it, beside the other;
        each operand is evaluated at most once, in order."""
        values: list[Any] = []

        def combine(all_of: bool) -> Any:
            for index, thunk in enumerate(operands):
                if index == len(values):
                    values.append(thunk())
                if bool(values[index]) is not all_of:
                    break
            return values[index]

        value = combine(conjunction)
        try:
            other = combine(not conjunction)
        except Exception as exc:
            other = exc
        self._saw(value, other)
        return value

    def branch(self, test: Any) -> Any:
        self._saw(True, False)  # a negated condition takes the other branch
        return test

    def value(self, original: Any, mutated: Any) -> Any:
        self._saw(original, mutated)
        return original


class _Shadow(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports one module from another file under its real name, with extra globals."""

    def __init__(self, module: str, path: Path, extra: dict[str, Any]) -> None:
        self.module, self.path, self.extra = module, path, extra

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname != self.module:
            return None
        return importlib.util.spec_from_loader(fullname, self, origin=str(self.path))

    def exec_module(self, module: ModuleType) -> None:
        module.__file__ = str(self.path)
        vars(module).update(self.extra)
        source = self.path.read_text(encoding="utf-8")
        code = compile(source, str(self.path), "exec", dont_inherit=True)
        exec(code, vars(module))


def work(job: dict[str, Any]) -> dict[str, Any]:
    """In a fresh child: import the job's source as its module, replay the specs (up to
    the first that fails, unless probing)."""
    from beatlog.suite.runner import Verdict, run_spec  # noqa: PLC0415 - preloaded by serve
    from beatlog.suite.spec import load_spec  # noqa: PLC0415

    probe = Probe()
    extra = {PROBE: probe} if job["probe"] else {}
    sys.meta_path.insert(0, _Shadow(job["module"], Path(job["source"]), extra))
    for path in job["specs"]:
        outcome = run_spec(load_spec(path))
        if outcome.verdict is not Verdict.PASSED:
            divergence = outcome.result.divergence if outcome.result else None
            reason = outcome.error or (divergence.message if divergence else "")
            return {"killed_by": outcome.spec.name, "reason": f"{outcome.verdict}: {reason}"}
    return {"evaluations": probe.evaluations, "differences": probe.differences}


def serve() -> None:
    """A worker process: imports beatlog once, then for each job (a JSON line on stdin)
    forks a fresh child that runs :func:`work`, and answers with a JSON line."""
    import beatlog.suite.runner  # noqa: F401, PLC0415 - so each child starts with it

    for line in sys.stdin:
        print(json.dumps(_forked(json.loads(line))), flush=True)


def _forked(job: dict[str, Any]) -> dict[str, Any]:
    reading, writing = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: its output must not reach the worker's answers
        os.close(reading)
        quiet = os.open(os.devnull, os.O_WRONLY)
        os.dup2(quiet, 1)
        os.dup2(quiet, 2)
        try:
            answer = work(job)
        except BaseException as exc:  # anything the mutant raises outside a replay
            answer = {"killed_by": "(worker)", "reason": f"raised {exc!r}"}
        with os.fdopen(writing, "w") as out:
            out.write(json.dumps(answer))
        os._exit(0)
    os.close(writing)
    with os.fdopen(reading) as answers:
        ready = select.select([answers], [], [], job["timeout_s"])[0]
        if not ready:
            os.kill(pid, signal.SIGKILL)
        text = answers.read() if ready else ""
    status = os.waitpid(pid, 0)[1]
    if text:
        done: dict[str, Any] = json.loads(text)
        return done
    reason = f"ran past {job['timeout_s']:.0f} s" if not ready else f"died (status {status})"
    return {"killed_by": "(worker)", "reason": reason}


class Workers:
    """Worker processes (this script with ``--worker``), each lent to one job at a time."""

    def __init__(self, count: int) -> None:
        self._idle: queue.SimpleQueue[subprocess.Popen[str]] = queue.SimpleQueue()
        self._all = [
            subprocess.Popen(
                [sys.executable, __file__, "--worker"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                text=True,
            )
            for _ in range(count)
        ]
        for worker in self._all:
            self._idle.put(worker)
        self._scratch = tempfile.TemporaryDirectory()

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc: object) -> None:
        for worker in self._all:
            worker.communicate()  # closes its stdin, so it ends, and its stdout
        self._scratch.cleanup()

    def replay(
        self, module: str, source: str, specs: Sequence[Path], *, probe: bool, timeout_s: float
    ) -> dict[str, Any]:
        """Replay the specs in a fresh child with ``source`` imported as ``module``."""
        with tempfile.NamedTemporaryFile(
            "w", suffix=".py", dir=self._scratch.name, encoding="utf-8", delete=False
        ) as file:
            file.write(source)
        job = {
            "module": module,
            "source": file.name,
            "specs": [str(path) for path in specs],
            "probe": probe,
            "timeout_s": timeout_s,
        }
        worker = self._idle.get()
        try:
            assert worker.stdin is not None
            assert worker.stdout is not None
            worker.stdin.write(json.dumps(job) + "\n")
            worker.stdin.flush()
            answer: dict[str, Any] = json.loads(worker.stdout.readline())
        finally:
            self._idle.put(worker)
            os.unlink(file.name)
        return answer


def run_mutant(
    mutant: Mutant, specs: Sequence[Path], workers: Workers, *, timeout_s: float = 120.0
) -> Result:
    """Replay the suite against the mutant; for a survivor, probe the mutated spot."""
    killed = workers.replay(
        mutant.module, mutated_source(mutant), specs, probe=False, timeout_s=timeout_s
    )
    if "killed_by" in killed:
        return Result(mutant, Outcome.KILLED, killed["killed_by"], killed["reason"])
    seen = workers.replay(
        mutant.module, instrumented_source(mutant), specs, probe=True, timeout_s=timeout_s
    )
    if "killed_by" in seen:
        raise RuntimeError(f"the instrumented original of {mutant.where} failed: {seen}")
    evaluations, differences = seen["evaluations"], seen["differences"]
    if not evaluations:
        outcome = Outcome.NOT_REACHED
    elif differences:
        outcome = Outcome.SURVIVED
    else:
        outcome = Outcome.POSSIBLY_EQUIVALENT
    return Result(mutant, outcome, evaluations=evaluations, differences=differences)


def dog_targets() -> list[Target]:
    """The dog's behavior code and its perception, as the module docstring says."""
    behaviors, perception = "beatlog_examples.dog.behaviors", "beatlog_examples.dog.perception"
    state = frozenset({"DogState"})
    return [
        Target(
            "behaviors",
            behaviors,
            _source(behaviors),
            skip=state | {"CHANGES", "changed_system", "__all__"},
        ),
        Target("perception", perception, _source(perception), skip=frozenset({"__all__"})),
        Target("perception", behaviors, _source(behaviors), only=state),
    ]


def _source(module: str) -> Path:
    found = importlib.util.find_spec(module)
    assert found is not None
    assert found.origin is not None
    return Path(found.origin)


def spread(items: Sequence[Mutant], limit: int | None) -> list[Mutant]:
    """At most ``limit`` items, evenly spaced, so a short run still covers every file."""
    if limit is None or limit >= len(items):
        return list(items)
    return [items[index * len(items) // limit] for index in range(limit)]


def summary(results: Sequence[Result], groups: Sequence[str]) -> list[dict[str, Any]]:
    """Per group: counts by outcome and the kill rates against the issue's targets."""
    rows = []
    for group in groups:
        mine = [result for result in results if result.mutant.group == group]
        counts = {outcome: sum(r.outcome is outcome for r in mine) for outcome in Outcome}
        draws = [result for result in mine if result.mutant.draw_parameter]
        killed = counts[Outcome.KILLED]
        can_change = len(mine) - counts[Outcome.POSSIBLY_EQUIVALENT]
        rows.append(
            {
                "group": group,
                "mutants": len(mine),
                **{outcome.value: count for outcome, count in counts.items()},
                "killed_share": killed / len(mine) if mine else math.nan,
                "killed_share_not_equivalent": killed / can_change if can_change else math.nan,
                "draw_parameters": len(draws),
                "draw_parameters_killed": sum(r.outcome is Outcome.KILLED for r in draws),
            }
        )
    return rows


def suite_mode(specs: Sequence[Path]) -> tuple[int, int]:
    """How many specs name a perception, and how many of those have logs with samples."""
    from beatlog.log.reader import SessionLogReader  # noqa: PLC0415
    from beatlog.suite.spec import load_spec  # noqa: PLC0415

    named = [spec for spec in map(load_spec, specs) if spec.perception is not None]
    with contextlib.ExitStack() as stack:
        readers = [stack.enter_context(SessionLogReader(spec.log)) for spec in named]
        sampled = sum(reader.header.samples_logged for reader in readers)
    return len(named), sampled


HEADERS = {
    Outcome.KILLED: "killed",
    Outcome.SURVIVED: "survived",
    Outcome.POSSIBLY_EQUIVALENT: "possibly equiv.",
    Outcome.NOT_REACHED: "not reached",
}


def report(console: Console, results: Sequence[Result], rows: Sequence[dict[str, Any]]) -> None:
    table = Table(title="Mutants of the dog against its DTC suite")
    for header in ("group", "mutants", *HEADERS.values(), "killed %", "excl. equiv.", "draws"):
        table.add_column(header, justify="left" if header == "group" else "right")
    for row in rows:
        table.add_row(
            row["group"],
            str(row["mutants"]),
            *(str(row[outcome.value]) for outcome in HEADERS),
            f"{row['killed_share']:.1%}",
            f"{row['killed_share_not_equivalent']:.1%}",
            f"{row['draw_parameters_killed']} / {row['draw_parameters']}",
        )
    console.print(table)
    console.print(
        "killed %: of all mutants; excl. equiv.: of those not possibly equivalent; "
        "draws: draw-parameter mutants killed"
    )
    survivors = [result for result in results if result.outcome is not Outcome.KILLED]
    console.print(f"\n{len(survivors)} survivors (evaluations of the spot that differed):")
    for result in survivors:
        mutant = result.mutant
        seen = f"{result.differences}/{result.evaluations}"
        console.print(
            f"  {mutant.group:<10} {mutant.where:<20} {mutant.description:<28} "
            f"{result.outcome:<29} {seen:<13} {mutant.code}",
            highlight=False,
            markup=False,
            soft_wrap=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="mutant processes")
    parser.add_argument("--limit", type=int, help="run at most N mutants, evenly spaced")
    parser.add_argument("--only", choices=["behaviors", "perception"], help="one group")
    parser.add_argument("--suite", type=Path, help="the suite's folder (default: the dog's)")
    parser.add_argument("--json", type=Path, help="also write every mutant's result here")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        serve()
        return

    from beatlog.suite.discovery import discover_specs  # noqa: PLC0415
    from beatlog_examples.dog import SUITE_DIR  # noqa: PLC0415

    console = Console()
    specs = [spec.path for spec in discover_specs([args.suite or SUITE_DIR])]
    targets = [t for t in dog_targets() if args.only in (None, t.group)]
    chosen = spread([m for target in targets for m in mutants(target)], args.limit)
    named, sampled = suite_mode(specs)
    console.print(
        f"{len(chosen)} mutants, {len(specs)} DTCs ({named} name a perception, "
        f"{sampled} of those with samples: "
        f"{'sensor-level' if sampled else 'state-level'} replay), {args.jobs} jobs"
    )
    started = time.perf_counter()
    with Workers(args.jobs) as workers:
        target = targets[0]
        baseline = workers.replay(
            target.module,
            target.path.read_text(encoding="utf-8"),
            specs,
            probe=False,
            timeout_s=600,
        )
        if "killed_by" in baseline:
            raise SystemExit(f"the unmutated suite fails: {baseline}")
        timeout_s = 10 * (time.perf_counter() - started) + 30
        with ThreadPoolExecutor(args.jobs) as pool, Progress(console=console) as progress:
            task = progress.add_task("mutants", total=len(chosen))
            futures = [
                pool.submit(run_mutant, mutant, specs, workers, timeout_s=timeout_s)
                for mutant in chosen
            ]
            results = []
            for future in futures:
                results.append(future.result())
                progress.advance(task)
    wall = time.perf_counter() - started
    groups = list(dict.fromkeys(target.group for target in targets))
    rows = summary(results, groups)
    report(console, results, rows)
    console.print(f"\n{wall:.0f} s wall with {args.jobs} jobs")
    if args.json:
        document = {
            "command": sys.argv,
            "specs": len(specs),
            "specs_with_perception": named,
            "specs_sensor_level": sampled,
            "wall_s": wall,
            "summary": rows,
            "mutants": [
                {**asdict(r), "mutant": {**asdict(r.mutant), "path": r.mutant.where}}
                for r in results
            ],
        }
        args.json.write_text(json.dumps(document, indent=2, default=str), encoding="utf-8")


if __name__ == "__main__":
    main()
