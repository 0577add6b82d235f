"""One version: the library's, its examples' and the changelog's latest release agree."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import beatlog

ROOT = Path(__file__).parent.parent


def test_the_examples_are_released_with_the_library() -> None:
    examples = tomllib.loads((ROOT / "examples" / "pyproject.toml").read_text(encoding="utf-8"))

    assert examples["project"]["version"] == beatlog.__version__


def test_the_changelog_names_the_version_as_its_latest_release() -> None:
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")

    releases = re.findall(r"^## \[(\d+\.\d+\.\d+)\] - \d{4}-\d{2}-\d{2}$", changelog, re.M)
    assert releases[0] == beatlog.__version__
