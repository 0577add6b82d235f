"""Who wrote the code a frame runs: the user, an installed package, or beatlog and the
standard library (exempt). A leak is blamed on the nearest frame of user code."""

from __future__ import annotations

import enum
import logging
import os
import site
import sysconfig
from pathlib import Path
from types import CodeType
from typing import Any

__all__ = ["Origin", "Origins"]


class Origin(enum.Enum):
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


class Origins:
    """Classifies source files by origin, once per file."""

    def __init__(self) -> None:
        paths = sysconfig.get_paths()
        self._beatlog = _BEATLOG_DIR
        self._libraries = _prefixes(
            paths["purelib"], paths["platlib"], *site.getsitepackages(), site.getusersitepackages()
        )
        self._stdlib = _prefixes(paths["stdlib"], paths["platstdlib"])
        self._logging = _package_dir(logging)
        self._known: dict[str, Origin] = {}

    def of(self, code: CodeType) -> Origin:
        filename = code.co_filename
        origin = self._known.get(filename)
        if origin is None:
            origin = self._known[filename] = self._classify(filename)
        return origin

    def _classify(self, filename: str) -> Origin:
        if filename.startswith("<"):  # frozen modules, exec'd strings
            return Origin.EXEMPT
        path = str(Path(filename).resolve())
        if path.startswith(self._beatlog):
            return Origin.EXEMPT
        if path.startswith(self._libraries):
            return Origin.LIBRARY
        if path.startswith(self._stdlib):
            return Origin.EXEMPT
        return Origin.USER

    def is_logging(self, code: CodeType) -> bool:
        return code.co_filename.startswith(self._logging)
