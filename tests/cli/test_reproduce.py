"""The ``reproduce:`` line of a failure reproduces that exact verdict: run as printed,
it fails at the same cycle in the same way, baseline and spec allowances included."""

from __future__ import annotations

import re
import shlex
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import pytest

from beatlog.cli.main import main
from tests.conftest import RecordFn, first_cycle_below
from tests.specs import CHANGED, write_spec

GEARED = "tests.systems:probe_system_changed_geared"
AGAIN = "tests.systems:probe_system_changed_again"
DIVERGENCE = re.compile(r"first divergence: cycle (\d+), t = [\d.]+ s, ([a-z ]+)")


class Verdict(NamedTuple):
    code: int
    cycle: int
    kind: str
    message: str
    reproduce: str


BeatlogVerdict = Callable[..., Verdict]
"""Runs a ``beatlog`` command in process and reads the verdict it printed."""


@pytest.fixture(autouse=True)
def wide(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "400")


@pytest.fixture
def beatlog(capsys: pytest.CaptureFixture[str]) -> BeatlogVerdict:
    def run(*argv: str | Path) -> Verdict:
        capsys.readouterr()  # what earlier commands printed
        code = main([str(arg) for arg in argv])
        out = capsys.readouterr().out
        found = DIVERGENCE.search(out)
        assert found is not None, out
        message = out[found.end() :].split("\n", 2)[1].strip(" │")
        (reproduce,) = re.findall(r"^reproduce: (.*)$", out, re.MULTILINE)
        return Verdict(code, int(found[1]), found[2].strip(), message, reproduce)

    return run


def spec_file(folder: Path, log: Path, system: str, **allowances: object) -> Path:
    """A spec in a folder whose name needs quoting in a shell."""
    return write_spec(folder, "avoid-pole", str(log), system, **allowances)


def rerun(beatlog: BeatlogVerdict, command: str) -> Verdict:
    argv = shlex.split(command)
    assert argv[0] == "beatlog"
    return beatlog(*argv[1:])


@pytest.fixture
def approved(beatlog: BeatlogVerdict, tmp_path: Path, record_probe: RecordFn) -> Path:
    """A spec whose intended change (near reacts earlier) has an approved baseline."""
    spec = spec_file(tmp_path / "my specs", record_probe(300), CHANGED)
    assert main(["test", "-j", "1", "--update", str(spec)]) == 1
    assert main(["approve", str(spec)]) == 0
    assert main(["test", "-j", "1", str(spec)]) == 0
    return spec


@pytest.mark.parametrize(
    ("system", "cycle", "kind", "message"),
    [
        (
            GEARED,
            first_cycle_below(0.8),
            "outputs",
            "outputs differ from the approved baseline",
        ),
        (
            AGAIN,
            first_cycle_below(0.7),
            "state changes",
            "behavior state changes differ from the approved baseline",
        ),
    ],
)
def test_a_baselined_dtc_reproduces_its_verdict(
    beatlog: BeatlogVerdict, approved: Path, system: str, cycle: int, kind: str, message: str
) -> None:
    spec = spec_file(approved.parent, approved.parent.parent / "probe.beatlog", system)

    suite = beatlog("test", "-j", "1", spec)

    assert (suite.code, suite.cycle, suite.kind, suite.message) == (1, cycle, kind, message)
    assert suite.reproduce == f"beatlog test '{spec}'"
    assert rerun(beatlog, suite.reproduce) == suite


def test_a_dtc_with_allowances_reproduces_its_verdict(
    beatlog: BeatlogVerdict, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    spec = spec_file(tmp_path / "my specs", log, GEARED, ignore_fields=["speed"])
    bare = beatlog("replay", log, "--system", GEARED)
    assert (bare.cycle, bare.kind) == (first_cycle_below(0.8), "outputs")

    suite = beatlog("test", "-j", "1", spec)

    assert (suite.code, suite.cycle, suite.kind) == (1, first_cycle_below(0.6), "state changes")
    assert rerun(beatlog, suite.reproduce) == suite


def test_a_plain_replay_reproduces_its_verdict(
    beatlog: BeatlogVerdict, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300, name="a session.beatlog")

    first = beatlog("replay", log, "--system", CHANGED, "--keep-going")

    assert first.reproduce == f"beatlog replay '{log}' --system {CHANGED} --keep-going"
    assert rerun(beatlog, first.reproduce) == first


def test_a_replay_with_fields_renamed_since_reproduces_its_verdict(
    beatlog: BeatlogVerdict, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    changed = "tests.systems:probe_system_ranged_changed"

    first = beatlog("replay", log, "--system", changed, "--rename-field", "distance=range")

    assert (first.code, first.cycle, first.kind) == (1, first_cycle_below(0.6), "state changes")
    assert first.reproduce == (
        f"beatlog replay {log} --system {changed} --rename-field distance=range"
    )
    assert rerun(beatlog, first.reproduce) == first
