"""What importing beatlog costs: the public names are imported on first use, so a
program, the CLI's ``--help`` or a suite worker loads only what it uses."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

PACKAGES = [
    "beatlog",
    "beatlog.analysis",
    "beatlog.audit",
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


def test_beatlog_replay_is_the_function_even_after_its_subpackage_is_imported() -> None:
    script = (
        "import sys, beatlog.replay.judge\n"
        "from beatlog import replay\n"
        "assert replay is beatlog.replay is sys.modules['beatlog.suite.approved'].replay\n"
    )

    subprocess.run([sys.executable, "-c", script], check=True)
