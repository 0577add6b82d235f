"""Writing the ``*.dtc.toml`` spec of a recorded scenario (shared by the example suites)."""

from __future__ import annotations

import json
from collections.abc import Iterable

__all__ = ["spec_text"]


def spec_text(
    *,
    name: str,
    purpose: str,
    procedure: Iterable[str],
    log: str,
    system: str,
    tags: Iterable[str],
    perception: str | None = None,
) -> str:
    """A DTC spec as TOML text (TOML basic strings are JSON strings)."""
    lines = [
        f"name = {json.dumps(name)}",
        f"purpose = {json.dumps(purpose)}",
        "procedure = [",
        *(f"    {json.dumps(step, ensure_ascii=False)}," for step in procedure),
        "]",
        f"log = {json.dumps(log)}",
        f"system = {json.dumps(system)}",
        *([] if perception is None else [f"perception = {json.dumps(perception)}"]),
        f"tags = {json.dumps(list(tags))}",
    ]
    return "\n".join(lines) + "\n"
