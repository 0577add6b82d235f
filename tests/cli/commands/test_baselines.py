"""``beatlog upgrade-baselines``: older baselines rewritten in format 6, each named; and
``review`` and ``approve`` refuse an older one in one line that names the command."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.baseline.file import expected_path, pending_path, read_baseline
from tests.commands import Beatlog, assert_error
from tests.specs import BASELINE_MAGIC, write_spec

pytestmark = pytest.mark.usefixtures("outside_ci", "wide_plain_console")

LINES = ['      12     0.360  "avoid": "off" -> "turning"', "      15     0.450  no state changes"]


def old_baseline(path: Path, version: int = 5) -> Path:
    """A baseline of format ``version`` at ``path``, for the log ``a.beatlog``."""
    text = "\n".join([BASELINE_MAGIC[version], f"# log a.beatlog sha256 {'0' * 64}", *LINES])
    path.write_text(text + "\n", encoding="utf-8")
    return path


def test_each_older_baseline_is_named_as_it_is_upgraded(beatlog: Beatlog, tmp_path: Path) -> None:
    first = old_baseline(tmp_path / "a.dtc.expected")
    second = old_baseline(tmp_path / "b.dtc.pending")

    run = beatlog("upgrade-baselines", tmp_path)
    again = beatlog("upgrade-baselines", tmp_path)

    assert (run.code, run.out, run.err) == (
        0,
        f"upgraded {first}: format 5 -> 6\nupgraded {second}: format 5 -> 6\n",
        "",
    )
    assert (again.code, again.out) == (0, "no baseline of an older format\n")
    assert read_baseline(first).expectation.quiet == ((15, 450_000_000),)


def test_a_damaged_baseline_is_one_line_and_exit_2(beatlog: Beatlog, tmp_path: Path) -> None:
    path = old_baseline(tmp_path / "a.dtc.expected")
    path.write_text(path.read_text(encoding="utf-8") + "  16  0.480  what\n", encoding="utf-8")

    run = beatlog("upgrade-baselines", path)

    assert_error(run, f"{path}: line 5: Expecting value: line 1 column 1 (char 0)")


@pytest.mark.parametrize("command", ["review", "approve"])
def test_review_and_approve_refuse_an_older_pending_baseline(
    beatlog: Beatlog, tmp_path: Path, command: str
) -> None:
    spec = write_spec(tmp_path, "a", "a.beatlog")
    pending = old_baseline(pending_path(spec))

    run = beatlog(command, spec)

    assert_error(
        run,
        f"{pending}: a format 5 baseline: "
        f"run 'beatlog upgrade-baselines {pending}' to rewrite it in format 6",
    )
    assert not expected_path(spec).exists()
