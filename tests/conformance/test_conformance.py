"""The conformance suite: each log in cases/ reads exactly as the JSON beside it says,
and the generator writes the same bytes again, so the writer is deterministic."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from typing import Any

import pytest

from beatlog.errors import CorruptLogError, LogError, NotABeatlogError, UnsupportedVersionError
from beatlog.log import SessionLogReader
from tests.conformance.generate import CASES, generate, json_value
from tests.factories import cycle_parts

ERRORS: dict[str, type[LogError]] = {
    "corrupt": CorruptLogError,
    "foreign": NotABeatlogError,
    "newer_version": UnsupportedVersionError,
}
NAMES = sorted(path.stem for path in CASES.glob("*.json"))


def read_document(log: Path) -> dict[str, Any]:
    """Everything the reader yields for a log, in the suite's JSON."""
    with SessionLogReader(log) as reader:
        cycles = [cycle_parts(cycle) for cycle in reader.cycles()]
        document: dict[str, Any] = json_value(
            {
                "format_version": reader.format_version,
                "header": reader.header,
                "cycles": cycles,
                "status": dataclasses.asdict(reader.status),
                "end": reader.end,
            }
        )
    return document


def exact(document: Any) -> str:
    """A document as text in which 1 and 1.0, or 1 and true, differ, and every float
    is written to round-trip: equal texts mean equal values bit for bit."""
    return json.dumps(document, indent=1, sort_keys=True, ensure_ascii=False)


def expectation(name: str) -> dict[str, Any]:
    expected: dict[str, Any] = json.loads((CASES / f"{name}.json").read_text(encoding="utf-8"))
    return expected


@pytest.mark.parametrize("name", [n for n in NAMES if "error" not in expectation(n)])
def test_a_readable_log_reads_exactly_as_its_json_says(name: str) -> None:
    assert exact(read_document(CASES / f"{name}.beatlog")) == exact(expectation(name))


@pytest.mark.parametrize("name", [n for n in NAMES if "error" in expectation(n)])
def test_a_bad_log_is_refused_as_its_json_says(name: str) -> None:
    expected = expectation(name)
    log = CASES / f"{name}.beatlog"
    with pytest.raises(
        ERRORS[expected["error"]], match=re.escape(expected["message_contains"])
    ) as refusal:
        read_document(log)
    assert refusal.value.path == log


def test_the_suite_covers_every_kind_of_case() -> None:
    documents = [expectation(name) for name in NAMES]
    assert {d["error"] for d in documents if "error" in d} == set(ERRORS)
    readable = [d for d in documents if "error" not in d]
    assert {d["format_version"] for d in readable} == {1, 2, 3, 4}
    assert {d["status"]["complete"] for d in readable} == {True, False}


def test_generating_again_gives_the_same_bytes(tmp_path: Path) -> None:
    written = generate(tmp_path)
    assert sorted(path.name for path in written) == sorted(path.name for path in CASES.iterdir())
    for path in written:
        assert path.read_bytes() == (CASES / path.name).read_bytes(), (
            f"{path.name} is not what the generator writes now: if the format or the "
            "writer changed on purpose, run python -m tests.conformance.generate"
        )
