"""A window of cycles: where a replay's batches are cut, how the log's end is judged,
and what the reproduce command and the notes say of it."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.errors import WindowError
from beatlog.log.reader import LogStatus
from beatlog.replay.session import ReplaySession
from beatlog.replay.verdict import DivergenceKind
from beatlog.replay.window import Window
from tests.conftest import RecordFn, probe_system


def cut(log: Path, window: Window) -> list[tuple[int, int]]:
    """The first and last cycle of each batch ``window`` hands on from ``log``."""
    spans: list[tuple[int, int]] = []
    with ReplaySession(log, probe_system()) as session:
        assert session.replayer is not None
        cycle = 0
        for batch in window.batches(session.reader.batches(), session.replayer):
            spans.append((cycle, cycle + len(batch) - 1))
            cycle += len(batch)
    return spans


def test_a_window_cuts_the_batches_where_it_opens_and_after_it_ends(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    whole = cut(log, Window())

    spans = cut(log, Window(whole[0][1] - 1, whole[0][1] + 1))

    assert spans[:2] == [(0, whole[0][1] - 2), (whole[0][1] - 1, whole[0][1])]
    assert spans[-1][1] == whole[0][1] + 1  # none read after its end


def test_a_window_that_ends_is_closed_and_one_that_does_not_is_not(
    record_probe: RecordFn,
) -> None:
    log = record_probe(300)
    ended, open_ = Window(0, 10), Window(10)

    cut(log, ended)
    cut(log, open_)

    assert (ended.closed, open_.closed) == (True, False)


def test_a_log_cut_short_ends_early_unless_allowed_and_a_window_past_it_is_refused() -> None:
    cut_short = LogStatus(complete=False, cycles=50)
    where = Path("dock.dtc.toml")

    ended = Window().log_ended(cut_short, where, 70, 0, allow_truncated=False)
    assert ended is not None
    assert (ended.kind, ended.cycle) == (DivergenceKind.LOG_ENDED, 50)
    assert Window().log_ended(cut_short, where, 50, 0, allow_truncated=True) is None
    assert Window(0, 10).log_ended(None, where, 11, 0, allow_truncated=False) is None
    with pytest.raises(WindowError, match="start_cycle 60 is past the log's last cycle"):
        Window(60).log_ended(cut_short, where, 50, 0, allow_truncated=True)


@pytest.mark.parametrize(
    ("window", "arguments", "note"),
    [
        (Window(), [], ""),
        (
            Window(1, 9),
            ["--start-cycle", "1", "--end-cycle", "9"],
            "1 cycle before the window replayed as recorded to rebuild the state, unjudged",
        ),
        (
            Window(20, fresh=True),
            ["--start-cycle", "20", "--fresh-start"],
            "fresh start: the behaviors start from rest at cycle 20; "
            "20 cycles before it not replayed",
        ),
        (Window(0, 5, fresh=True), ["--end-cycle", "5"], ""),
    ],
)
def test_a_window_says_itself_in_the_reproduce_command_and_the_notes(
    window: Window, arguments: list[str], note: str
) -> None:
    assert (window.arguments(), window.note()) == (arguments, note)
