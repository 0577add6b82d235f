"""Baseline files written: plain text while a review can read them as a diff, one zstd
frame of that text past :data:`COMPRESS_BYTES`, so that a retune that departs in every
cycle stays compact."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.baseline.file import ZSTD_MAGIC, log_digest, pending_path, read_baseline
from beatlog.baseline.write import COMPRESS_BYTES, HEADER, write_baseline
from beatlog.replay.baseline import Baseline, TracedOutput
from tests.commands import Beatlog
from tests.specs import write_spec
from tests.systems import record_headway

CYCLES = 2_500
"""A session of the length of the driving DTCs whose retune wrote 157-189 KB each."""
BYTES_A_CYCLE = 12
"""What a cycle's one retuned output may cost, compressed: its value's 17 digits hold
about 7 bytes of information, the cycle and time columns about one more (written as
text, the line costs 56)."""


def _written(folder: Path, cycles: int) -> tuple[Path, Baseline]:
    log = folder / "a.beatlog"
    log.write_bytes(b"a recording")
    outputs = tuple(TracedOutput(c, c * 30_000_000, "accel", c / 7) for c in range(cycles))
    baseline = Baseline((), outputs, open_loop=(0, 0))
    path = folder / "a.dtc.expected"
    write_baseline(
        path, spec_name="a", log_name=log.name, digest=log_digest(log), baseline=baseline
    )
    return path, baseline


def test_a_short_baseline_is_plain_text_and_a_long_one_one_zstd_frame(tmp_path: Path) -> None:
    (tmp_path / "short").mkdir()
    (tmp_path / "long").mkdir()
    short, _ = _written(tmp_path / "short", 10)
    long, baseline = _written(tmp_path / "long", COMPRESS_BYTES // 40)

    assert short.read_text(encoding="utf-8").startswith(HEADER + "\n")
    assert long.read_bytes().startswith(ZSTD_MAGIC)
    assert read_baseline(long).whole == baseline


@pytest.mark.usefixtures("outside_ci")
def test_a_retune_that_departs_in_every_cycle_writes_a_compact_baseline(
    tmp_path: Path, beatlog: Beatlog
) -> None:
    log = record_headway(tmp_path / "follow.beatlog", CYCLES)
    spec = write_spec(tmp_path, "follow", log, "tests.systems:headway_system_retuned")

    assert beatlog("test", "--update", spec).code == 1

    pending = read_baseline(pending_path(spec))
    assert len(pending.whole.outputs) == CYCLES, "the output departs in every cycle"
    assert pending_path(spec).stat().st_size < BYTES_A_CYCLE * CYCLES
