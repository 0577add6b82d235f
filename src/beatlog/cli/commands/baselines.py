"""The baseline commands: ``beatlog review`` shows each pending baseline change and asks
whether to accept it, ``beatlog approve`` accepts the pending baselines of DTC specs, and
``beatlog upgrade-baselines`` rewrites baselines of older formats in the current one."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.cli.arguments import add_paths
from beatlog.cli.common import EXIT_OK

if TYPE_CHECKING:
    from rich.console import Console

__all__ = [
    "add_approve_arguments",
    "add_review_arguments",
    "add_upgrade_arguments",
    "approve",
    "review",
    "upgrade",
]


def add_review_arguments(review: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog review``."""
    add_paths(review, "specs or folders with pending baselines")


def review(args: argparse.Namespace, console: Console) -> int:
    """Review what is pending (see :func:`beatlog.cli.baselines.review`)."""
    from beatlog.cli.baselines import review

    review(args.paths, console)
    return EXIT_OK


def add_approve_arguments(approve: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog approve``."""
    approve.add_argument(
        "paths", nargs="+", type=Path, help="specs or folders whose pending baselines to accept"
    )


def approve(args: argparse.Namespace, console: Console) -> int:
    """Accept everything pending under the paths, naming each."""
    from beatlog.cli.baselines import approve_command

    approve_command(args.paths, console)
    return EXIT_OK


def add_upgrade_arguments(upgrade: argparse.ArgumentParser) -> None:
    """The arguments of ``beatlog upgrade-baselines``."""
    add_paths(upgrade, "baselines, specs, or folders with approved and pending baselines")


def upgrade(args: argparse.Namespace, console: Console) -> int:
    """Upgrade each older baseline given, naming each and the format it had."""
    from beatlog.baseline.upgrade import upgrade_baselines

    upgraded = upgrade_baselines(args.paths, _recording)
    if not upgraded:
        console.print("no baseline of an older format", highlight=False)
    for path, version in upgraded:
        console.print(f"[green]upgraded[/] {path}: format {version} -> 6", highlight=False)
    return EXIT_OK


def _recording(baseline: Path, log_name: str) -> Path:
    """The recording its spec names, else the one named ``log_name`` beside it."""
    from beatlog.baseline.file import spec_path
    from beatlog.suite.spec import load_spec

    spec = spec_path(baseline)
    return load_spec(spec).log if spec.is_file() else baseline.with_name(log_name)
