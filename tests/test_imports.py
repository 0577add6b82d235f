"""What importing beatlog costs: the public names are imported on first use, so a
program, the CLI's ``--help`` or a suite worker loads only what it uses. And which way
imports point: every one from a layer to a lower one, none in a cycle of files; and
every module small enough to hold one job."""

from __future__ import annotations

import ast
import graphlib
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import beatlog

PACKAGES = [
    "beatlog",
    "beatlog.analysis",
    "beatlog.audit",
    "beatlog.baseline",
    "beatlog.log",
    "beatlog.model",
    "beatlog.record",
    "beatlog.replay",
    "beatlog.report",
    "beatlog.suite",
]
HEAVY = ["numpy", "rich", "multiprocessing", "beatlog.audit", "matplotlib"]


def modules_after(statement: str) -> set[str]:
    """The modules a fresh interpreter holds after running ``statement``."""
    script = f"import sys\n{statement}\nprint('\\n'.join(sys.modules))"
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    return set(run.stdout.split())


@pytest.mark.parametrize("statement", ["import beatlog", "import beatlog.cli.main"])
def test_importing_beatlog_or_its_command_loads_nothing_heavy(statement: str) -> None:
    modules = modules_after(statement)

    assert [name for name in HEAVY if name in modules] == []


def test_scalar_draws_load_no_numpy() -> None:
    modules = modules_after(
        "from beatlog.model.random import RecordingRandom\n"
        "source = RecordingRandom(seed=1)\n"
        "source.random(), source.uniform(0, 1), source.gauss(0, 1), source.randint(1, 6)\n"
        "source.choice('abc')\n"
    )

    assert "numpy" not in modules


def test_the_command_loads_no_engine_before_it_knows_the_subcommand() -> None:
    modules = modules_after("import beatlog.cli.main")

    assert "beatlog.replay.judge" not in modules
    assert "msgspec" not in modules


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_of_a_package_is_there_when_asked_for(package: str) -> None:
    module = importlib.import_module(package)

    for name in module.__all__:
        assert getattr(module, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        module.nothing  # noqa: B018


@pytest.mark.parametrize(
    ("package", "name", "old"),
    [
        ("beatlog.replay", "Baseline", "Expectation"),
        ("beatlog.baseline", "BaselineFile", "Baseline"),
    ],
)
def test_the_baseline_has_one_public_name_whole_and_one_as_a_file(
    package: str, name: str, old: str
) -> None:
    module = importlib.import_module(package)

    assert name in module.__all__
    with pytest.raises(AttributeError):
        getattr(module, old)


def test_beatlog_replay_is_the_subpackage_and_called_replays_a_log() -> None:
    script = (
        "import sys, types, beatlog, beatlog.replay as subpackage\n"
        "from beatlog import replay\n"
        "assert replay is beatlog.replay is subpackage is sys.modules['beatlog.replay']\n"
        "assert isinstance(replay, types.ModuleType) and replay.Divergence\n"
        "assert 'beatlog.suite.approved' not in sys.modules\n"
        "try:\n"
        "    replay('missing.beatlog', 'tests.conftest:probe_system')\n"
        "except beatlog.BeatlogError as error:\n"
        "    assert 'missing.beatlog' in str(error), error\n"
        "else:\n"
        "    raise AssertionError('replayed a missing log')\n"
    )

    subprocess.run([sys.executable, "-c", script], check=True)


LAYERS = [
    {"_version", "errors"},
    {"log"},
    {"model"},
    {"project"},
    {"replay"},
    {"analysis"},
    {"audit", "record"},
    {"baseline"},
    {"suite"},
    {"report"},
    {"adapters", "pytest_plugin"},
    {"cli"},
    {"__init__", "__main__"},
]
"""beatlog's parts (its subpackages and top-level modules), from the ground up: a part
imports its own modules and those of the layers below it, never one above or beside.
The log format knows nothing of the execution model, the model nothing of replay or of
the user's project (its configuration, its code and the leak watch over that code); the
record engine and the determinism audit both replay under that watch, neither knowing
the other; the reports render what suites and replays give, and the suite session puts
suites and reports together for the shells (the CLI, the pytest plugin);
``beatlog/__init__`` is the API, ``beatlog/__main__`` the command."""

SOURCE = Path(beatlog.__file__).parent


class Imported:
    """Every import of one of beatlog's modules: the modules it names, and those it
    names outside ``if TYPE_CHECKING:`` (which run)."""

    def __init__(self, path: Path) -> None:
        parts = path.relative_to(SOURCE.parent).with_suffix("").parts
        self.name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        self.part = parts[1].removesuffix(".py") if len(parts) > 1 else "__init__"
        package = self.name if path.name == "__init__.py" else self.name.rpartition(".")[0]
        self.all: set[str] = set()
        self.run: set[str] = set()
        self._visit(ast.parse(path.read_text(encoding="utf-8")), package, typing=False)

    def _visit(self, node: ast.AST, package: str, *, typing: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and ast.unparse(child.test) == "TYPE_CHECKING":
                self._visit(child, package, typing=True)
                continue
            names: list[str] = []
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom):
                module = child.module or ""
                if child.level:
                    base = package.split(".")[: len(package.split(".")) - child.level + 1]
                    module = ".".join([*base, module] if module else base)
                names = [module, *(f"{module}.{alias.name}" for alias in child.names)]
            found = {name for name in names if name.split(".")[0] == "beatlog"}
            self.all |= found
            if not typing:
                self.run |= found
            self._visit(child, package, typing=typing)


MODULES = {imported.name: imported for imported in map(Imported, SOURCE.rglob("*.py"))}


def layer(part: str) -> int:
    return next(index for index, parts in enumerate(LAYERS) if part in parts)


def test_every_part_of_beatlog_has_a_layer() -> None:
    parts = {imported.part for imported in MODULES.values()}

    assert parts == set().union(*LAYERS)


def test_no_import_runs_up_the_layers_or_across_one() -> None:
    upward = sorted(
        f"{module.name} imports {name}"
        for module in MODULES.values()
        for name in module.all
        if name in MODULES
        and MODULES[name].part != module.part
        and layer(MODULES[name].part) >= layer(module.part)
    )

    assert upward == []


def test_every_module_is_under_400_lines() -> None:
    long = sorted(
        f"{path.relative_to(SOURCE).as_posix()}: {lines} lines"
        for path in SOURCE.rglob("*.py")
        if (lines := len(path.read_text(encoding="utf-8").splitlines())) >= 400
    )

    assert long == []


def test_no_import_cycle_spans_files() -> None:
    """Not even through imports made for the type checker alone: files that name each
    other are one idea cut in two."""
    graph = {
        module.name: {name for name in module.all if name in MODULES and name != module.name}
        for module in MODULES.values()
    }

    graphlib.TopologicalSorter(graph).prepare()  # raises CycleError, naming the cycle


REPOSITORY = Path(__file__).resolve().parent.parent
SUITES = {
    "tests": ["tests", "examples/tests"],
    "benchmarks": ["bench", "examples/bench"],
}
"""The library's and the examples' tests, and their benchmarks: neither side imports the
other, but for :data:`SHARED`."""
SHARED = {"tests.crafting"}
"""What the benchmarks take from the tests: the session logs crafted by hand, hostile ones
included, that the integrity benchmark times the reader on (a test tool, not shipped)."""


def imported_modules(folder: Path) -> set[str]:
    """The top-level names of every module the Python files under ``folder`` import,
    but for :data:`SHARED`."""
    names: set[str] = set()
    for path in folder.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            found: list[str] = []
            if isinstance(node, ast.Import):
                found = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                found = [node.module, *(f"{node.module}.{alias.name}" for alias in node.names)]
            if not SHARED.intersection(found):
                names |= {name.split(".")[0] for name in found}
    return names


def own_modules(folder: Path) -> set[str]:
    """The names the files under ``folder`` are imported by: its package, or (a folder of
    scripts) each script's."""
    if (folder / "__init__.py").is_file():
        return {folder.name}
    return {path.stem for path in folder.glob("*.py")}


@pytest.mark.parametrize(("side", "other"), [("tests", "benchmarks"), ("benchmarks", "tests")])
def test_tests_and_benchmarks_import_nothing_of_each_other(side: str, other: str) -> None:
    theirs = set().union(*(own_modules(REPOSITORY / folder) for folder in SUITES[other]))
    imported = set().union(*(imported_modules(REPOSITORY / folder) for folder in SUITES[side]))

    assert sorted(imported & theirs) == []
