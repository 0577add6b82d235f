"""What pip reads: every extra spelt as pip spells it, and each ``beatlog[...]`` the
code and docs print naming extras there are, so that the command they give installs
what it says with every pip (pip 23.2 matches extras only as published)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).parent.parent
_PRINTED = re.compile(r"beatlog\[([^\]]+)\]")


def _extras() -> set[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return set(project["optional-dependencies"])


def test_every_extra_has_its_normalised_name() -> None:
    assert {re.sub(r"[-_.]+", "-", name).lower() for name in _extras()} == _extras()


def test_every_extra_printed_is_one_there_is() -> None:
    files = [
        path
        for folder in ("src", "examples", "docs")
        for path in (ROOT / folder).rglob("*")
        if path.suffix in {".py", ".md", ".toml"}
    ]
    printed = {
        (path.relative_to(ROOT).as_posix(), extra.strip())
        for path in files
        for listed in _PRINTED.findall(path.read_text(encoding="utf-8"))
        for extra in listed.split(",")
    }

    assert {(path, extra) for path, extra in printed if extra not in _extras()} == set()
