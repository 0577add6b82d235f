"""The dog's variants: its unchanged behaviors pass every variant of its suite, and a bug
planted where no recording goes is found by a variant and shrunk to a short window."""

from __future__ import annotations

import re
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from beatlog.cli.main import main
from beatlog.suite.spec import load_spec
from beatlog_examples.dog import SUITE_DIR

PLANTED = '''
"""The dog with a bug planted in get_up: dragged backwards faster than 0.21 m/s, which
no recording of the suite reaches (back-touch comes closest, at 0.206 m/s), it braces
by walking forward at twice the speed, beyond what its legs can do."""

from beatlog.model.behavior import PriorityArbiter
from beatlog_examples.dog.behaviors import BEHAVIORS, DogState, GetUp, Tuning


class Braced(GetUp):
    def step(self, rs, ctx):
        if rs.speed < -0.21:
            return {"motion": "walk", "speed": -2.0 * rs.speed, "turn": 0.0}
        return super().step(rs, ctx)


def system():
    tuning = Tuning()
    rest = (kind(tuning) for kind in BEHAVIORS[1:])
    return PriorityArbiter([Braced(tuning), *rest], robot_state=DogState)
'''


@pytest.fixture
def planted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """The dog's shortest DTC, back-touch, in a folder of its own, against the dog with
    the bug planted (``planted_dog:system``); the working folder."""
    for name in ("back-touch.beatlog", "back-touch.dtc.toml"):
        shutil.copy(SUITE_DIR / name, tmp_path / name)
    spec = tmp_path / "back-touch.dtc.toml"
    text = spec.read_text(encoding="utf-8")
    spec.write_text(text.replace("beatlog_examples.dog:system", "planted_dog:system"))
    (tmp_path / "planted_dog.py").write_text(PLANTED, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")  # the panels' lines whole
    monkeypatch.setattr(sys, "path", list(sys.path))  # main() adds the working folder
    yield tmp_path
    sys.modules.pop("planted_dog", None)


@pytest.mark.slow  # every DTC of the suite, three times
def test_the_unchanged_dog_passes_every_variant_of_its_suite(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("COLUMNS", "100")

    code = main(["test", str(SUITE_DIR), "--variants", "2", "-j", "2"])

    out = capsys.readouterr().out
    assert code == 0, out
    assert "66 passed (44 of them variants), not listed" in out
    assert out.splitlines()[-1].startswith("66 passed, 0 failed in ")
    assert len(out.splitlines()) <= 12
    assert list(SUITE_DIR.glob("*.variant-*")) == []


@pytest.mark.slow  # a few replays of a 1000-cycle DTC
def test_a_bug_where_no_recording_goes_is_found_by_a_variant_and_shrunk(
    planted: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["test", "back-touch.dtc.toml", "-j", "1"]) == 0
    capsys.readouterr()

    assert main(["test", "back-touch.dtc.toml", "--variants", "24", "-j", "1"]) == 1
    found = capsys.readouterr().out
    written = sorted(planted.glob("back-touch.variant-*.dtc.toml"))
    assert written
    assert "outputs_within_range" in found
    assert re.search(r"speed 0\.4\d* m/s beyond ±0\.3", found)
    assert f"written: {written[0].name} (a failing variant" in found

    assert main(["shrink", written[0].name]) == 0
    report = capsys.readouterr().out
    assert "shrunk invariant outputs_within_range at cycle 268: 269 cycles" in report
    shrunk = load_spec(written[0].with_name(written[0].name.replace(".dtc", ".shrunk.dtc")))
    assert shrunk.end_cycle == 268
    assert shrunk.start_cycle is not None
    assert shrunk.end_cycle - shrunk.start_cycle < 300

    assert main(["test", shrunk.path.name, "-j", "1"]) == 1
    again = capsys.readouterr().out
    assert "outputs_within_range" in again
    assert "cycle 268" in again
