"""Parametrizations over many committed inputs: one runs by default, the rest are slow."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import pytest


def one_by_default(values: Sequence[Any], default: Any, ids: Callable[[Any], str]) -> list[Any]:
    """``values`` as parameters where only ``default`` runs in the default selection and
    the others are marked ``slow``: the default run checks the behavior on one
    representative input, ``-m slow`` on every other one."""
    assert default in values, default
    return [
        pytest.param(value, id=ids(value), marks=() if value == default else pytest.mark.slow)
        for value in values
    ]
