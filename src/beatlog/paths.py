"""Opening the files users name, safely: regular files only, so nothing read can block."""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = ["irregular_file_problem"]


def irregular_file_problem(path: Path) -> str | None:
    """Why ``path`` cannot be read as a file, or None when it is a regular file.

    A FIFO, socket or device could block a reader forever or never end, so they are
    refused before anything opens them.
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return "no such file"
    except OSError as exc:
        return f"cannot open: {exc.strerror}"
    if stat.S_ISDIR(mode):
        return "is a directory"
    if not stat.S_ISREG(mode):
        return "is not a regular file (a FIFO, socket or device)"
    return None
