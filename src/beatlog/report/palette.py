"""State colours, the same in every chart: a fixed palette and a stable key per state.

An HTML report's stylesheet gives each state's key one colour by its first appearance
in the report (:func:`state_styles`), so a state looks the same in every chart; a chart
alone falls back to a colour chosen by its key.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable

__all__ = ["PALETTE", "fallback_color", "state_key", "state_styles"]

PALETTE = (
    "#1f77b4",
    "#aec7e8",
    "#ff7f0e",
    "#ffbb78",
    "#2ca02c",
    "#98df8a",
    "#d62728",
    "#ff9896",
    "#9467bd",
    "#c5b0d5",
    "#8c564b",
    "#c49c94",
    "#e377c2",
    "#f7b6d2",
    "#7f7f7f",
    "#c7c7c7",
    "#bcbd22",
    "#dbdb8d",
    "#17becf",
    "#9edae5",
)
"""matplotlib's ``tab20``: ten hues, each dark and light."""


def state_key(label: str) -> str:
    """A CSS class for a state label, the same in every process and run: ``s-`` and hex."""
    return "s-" + hashlib.blake2b(label.encode(), digest_size=4).hexdigest()


def fallback_color(label: str) -> str:
    """The colour a state has by its key alone, where no stylesheet says otherwise."""
    return PALETTE[int(state_key(label)[2:], 16) % len(PALETTE)]


def state_styles(labels: Iterable[str]) -> str:
    """CSS rules giving each state (in order of first appearance) the next palette colour."""
    ordered = dict.fromkeys(labels)
    return "".join(
        f".{state_key(label)}{{fill:{PALETTE[index % len(PALETTE)]}}}"
        for index, label in enumerate(ordered)
    )
