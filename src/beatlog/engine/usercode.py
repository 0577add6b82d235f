"""Where user code failed: its traceback cut down to the user's frames, and its site."""

from __future__ import annotations

import importlib
import os
import traceback
from pathlib import Path

__all__ = ["failure_site", "user_traceback"]

_PACKAGE_DIR = str(Path(__file__).parent.parent) + os.sep
_IMPORTLIB_DIR = str(Path(importlib.__file__).parent)


def _is_users(frame: traceback.FrameSummary) -> bool:
    """beatlog's own frames and the import machinery's are not the user's."""
    filename = frame.filename
    if filename.startswith(("<frozen importlib", _IMPORTLIB_DIR)):
        return False
    return not filename.startswith(_PACKAGE_DIR)


def user_traceback(exc: BaseException) -> str:
    """The traceback with beatlog's own frames left out, so it starts in the user's code."""
    frames = [frame for frame in traceback.extract_tb(exc.__traceback__) if _is_users(frame)]
    lines = ["Traceback (most recent call last):\n", *traceback.format_list(frames)]
    lines.extend(traceback.format_exception_only(exc))
    return "".join(lines)


def failure_site(exc: BaseException) -> str | None:
    """``line N of FILE`` where the user's code failed: the innermost user frame, or
    where a syntax error is; None when no user frame is known."""
    if isinstance(exc, SyntaxError) and exc.filename and exc.lineno:
        return f"line {exc.lineno} of {exc.filename}"
    frames = [frame for frame in traceback.extract_tb(exc.__traceback__) if _is_users(frame)]
    if not frames:
        return None
    return f"line {frames[-1].lineno} of {frames[-1].filename}"
