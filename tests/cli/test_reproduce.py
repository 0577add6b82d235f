"""The ``reproduce:`` line of a failure reproduces that exact verdict: run as printed,
it fails at the same cycle in the same way, baseline and spec allowances included."""

from __future__ import annotations

import json
import re
import shlex
from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import pytest

from beatlog.cli.main import main
from beatlog.model.behavior import PriorityArbiter
from beatlog.model.context import Context, Outputs
from tests.conftest import Dice, Near, Probe, RecordFn, distances, probe_system

HERE = "tests.cli.test_reproduce"
DIVERGENCE = re.compile(r"first divergence: cycle (\d+), t = [\d.]+ s, ([a-z ]+)")


class Geared(Dice):
    """Dice with a new motor gain near the obstacle: a change in outputs only."""

    def step(self, rs: Probe, ctx: Context) -> Outputs | None:
        outputs = super().step(rs, ctx)
        assert outputs is not None
        return {**outputs, "speed": 0.55 if rs.distance < 0.8 else 0.5}


def earlier() -> PriorityArbiter[Probe]:
    """Near reacts at 0.6 instead of 0.5: the intended change that gets approved."""
    return probe_system(0.6)


def earlier_geared() -> PriorityArbiter[Probe]:
    """On top of the approved change, a changed motor gain."""
    return PriorityArbiter([Near(0.6), Geared()], robot_state=Probe)


def earlier_still() -> PriorityArbiter[Probe]:
    """On top of the approved change, near reacts earlier still: new state changes."""
    return probe_system(0.7)


def first_below(threshold: float) -> int:
    return next(t for t, d in enumerate(distances(300)) if d < threshold)


class Verdict(NamedTuple):
    code: int
    cycle: int
    kind: str
    message: str
    reproduce: str


Beatlog = Callable[..., Verdict]
"""Runs a ``beatlog`` command in process and reads the verdict it printed."""


@pytest.fixture(autouse=True)
def not_ci_and_wide(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setenv("COLUMNS", "400")


@pytest.fixture
def beatlog(capsys: pytest.CaptureFixture[str]) -> Beatlog:
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
    folder.mkdir(parents=True, exist_ok=True)
    keys = {
        "name": "avoid-pole",
        "purpose": "The probe turns away from the pole.",
        "procedure": ["Drive the probe toward the pole and back, twice."],
        "log": str(log),
        "system": system,
        **allowances,
    }
    path = folder / "avoid-pole.dtc.toml"
    path.write_text("".join(f"{k} = {json.dumps(v)}\n" for k, v in keys.items()), "utf-8")
    return path


def rerun(beatlog: Beatlog, command: str) -> Verdict:
    argv = shlex.split(command)
    assert argv[0] == "beatlog"
    return beatlog(*argv[1:])


@pytest.fixture
def approved(beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn) -> Path:
    """A spec whose intended change (near reacts earlier) has an approved baseline."""
    spec = spec_file(tmp_path / "my specs", record_probe(300), f"{HERE}:earlier")
    assert main(["test", "-j", "1", "--update", str(spec)]) == 1
    assert main(["approve", str(spec)]) == 0
    assert main(["test", "-j", "1", str(spec)]) == 0
    return spec


@pytest.mark.parametrize(
    ("system", "cycle", "kind", "message"),
    [
        (
            "earlier_geared",
            first_below(0.8),
            "outputs",
            "outputs differ from the approved baseline",
        ),
        (
            "earlier_still",
            first_below(0.7),
            "state changes",
            "behavior state changes differ from the approved baseline",
        ),
    ],
)
def test_a_baselined_dtc_reproduces_its_verdict(
    beatlog: Beatlog, approved: Path, system: str, cycle: int, kind: str, message: str
) -> None:
    spec = spec_file(approved.parent, approved.parent.parent / "probe.beatlog", f"{HERE}:{system}")

    suite = beatlog("test", "-j", "1", spec)

    assert (suite.code, suite.cycle, suite.kind, suite.message) == (1, cycle, kind, message)
    assert suite.reproduce == f"beatlog test '{spec}'"
    assert rerun(beatlog, suite.reproduce) == suite


def test_a_dtc_with_allowances_reproduces_its_verdict(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300)
    spec = spec_file(tmp_path / "my specs", log, f"{HERE}:earlier_geared", ignore_fields=["speed"])
    bare = beatlog("replay", log, "--system", f"{HERE}:earlier_geared")
    assert (bare.cycle, bare.kind) == (first_below(0.8), "outputs")

    suite = beatlog("test", "-j", "1", spec)

    assert (suite.code, suite.cycle, suite.kind) == (1, first_below(0.6), "state changes")
    assert rerun(beatlog, suite.reproduce) == suite


def test_a_plain_replay_reproduces_its_verdict(
    beatlog: Beatlog, tmp_path: Path, record_probe: RecordFn
) -> None:
    log = record_probe(300, name="a session.beatlog")

    first = beatlog("replay", log, "--system", f"{HERE}:earlier", "--keep-going")

    assert first.reproduce == f"beatlog replay '{log}' --system {HERE}:earlier --keep-going"
    assert rerun(beatlog, first.reproduce) == first
