"""How a suite's DTCs become a cluster's tasks: each DTC once, in order, within the
bounds of a task (shrinking to the end), and each URL log fetched ahead by one task of
the thread that replays it."""

from __future__ import annotations

from pathlib import Path

import pytest

from beatlog.suite.packing import (
    FETCHED_AHEAD,
    TASK_BYTES,
    TASK_BYTES_AT_THE_END,
    TASKS_PER_THREAD,
    fetched_ahead,
    tasks,
)
from beatlog.suite.spec import DtcSpec


def url_specs(folder: Path, count: int) -> list[DtcSpec]:
    """``count`` DTCs, every fifth of a local log, the others of a log behind a URL."""
    return [
        DtcSpec(folder, f"d{n}", "", (), Path(f"d{n}.beatlog"), None, log_url=f"s3://b/d{n}")
        if n % 5
        else DtcSpec(folder, f"d{n}", "", (), folder / f"d{n}.beatlog", None)
        for n in range(count)
    ]


@pytest.mark.parametrize(("dtcs", "threads"), [(0, 2), (1, 2), (3, 2), (40, 2), (41, 3), (9, 16)])
def test_each_url_log_past_the_first_of_each_thread_is_fetched_ahead_by_one_task(
    tmp_path: Path, dtcs: int, threads: int
) -> None:
    ordered = url_specs(tmp_path, dtcs)

    ahead = fetched_ahead([[spec] for spec in ordered], threads)

    fetched = [url for urls in ahead for url, _ in urls]
    assert sorted(fetched) == sorted(
        spec.log_url for spec in ordered[threads:] if spec.log_url is not None
    )
    at = {spec.log_url: index for index, spec in enumerate(ordered)}
    for index, urls in enumerate(ahead):
        assert len(urls) <= FETCHED_AHEAD
        assert all(at[url] > index for url, _ in urls)  # a later DTC's, never its own


@pytest.mark.parametrize(("sizes", "threads"), [([3] * 7 + [1] * 40, 2), ([1] * 100, 3)])
def test_a_task_of_several_dtcs_has_the_next_of_its_thread_fetched_and_its_own(
    tmp_path: Path, sizes: list[int], threads: int
) -> None:
    ordered = url_specs(tmp_path, len(sizes))
    grouped = [[ordered[index] for index in task] for task in tasks(sizes, threads)]

    ahead = fetched_ahead(grouped, threads)

    firsts = {grouped[index][0].log_url for index in range(min(threads, len(grouped)))}
    fetched = [url for urls in ahead for url, _ in urls]
    assert sorted(fetched) == sorted(
        spec.log_url for spec in ordered if spec.log_url is not None and spec.log_url not in firsts
    )
    task_of = {spec.log_url: index for index, task in enumerate(grouped) for spec in task}
    for index, urls in enumerate(ahead):
        later = [task_of[url] for url, _ in urls]
        assert all(at % threads == index % threads for at in later)  # by its own thread
        own = [at for at in later if at == index]
        assert not own or index < threads  # only a thread's first task fetches its own
        assert all(at <= index + threads * FETCHED_AHEAD for at in later)
        if index + threads < len(grouped):  # the next task of its thread is fetched by now
            assert {task_of[url] for urls in ahead[: index + 1] for url, _ in urls} >= {
                at
                for at in range(index % threads, index + threads + 1, threads)
                if any(spec.log_url for spec in grouped[at])
            } - {index % threads}


SMALL, MID, BIG = TASK_BYTES // 26, TASK_BYTES * 2 // 5, TASK_BYTES


@pytest.mark.parametrize(
    ("sizes", "threads"),
    [
        ([], 2),
        ([SMALL] * 3, 2),
        ([BIG * 2, BIG, BIG - 1, *[SMALL] * 200, None, *[SMALL] * 50], 2),
        ([SMALL] * 1000, 2),
        ([SMALL] * 1000, 160),
        ([BIG + 1, None, *[SMALL] * 400, None, *[1] * 300, 0, 0], 4),
        ([BIG // 2 + 1] * 64, 1),
    ],
)
def test_tasks_hold_every_dtc_once_in_order_within_their_bounds(
    sizes: list[int | None], threads: int
) -> None:
    grouped = tasks(sizes, threads)

    assert [index for task in grouped for index in task] == list(range(len(sizes)))
    assert all(len(task) == 1 for task in grouped[:threads])  # its first outcome soon
    most = max(1, len(sizes) // (threads * TASKS_PER_THREAD))
    left = sum(TASK_BYTES if size is None else size for size in sizes)
    for task in grouped:
        weights = [sizes[index] for index in task]
        if len(task) > 1:  # within its share of the bytes left: tasks shrink at the end
            assert None not in weights
            share = max(TASK_BYTES_AT_THE_END, min(TASK_BYTES, left // (2 * threads)))
            assert sum(weight or 0 for weight in weights) <= share
            assert len(task) <= most
            assert all((weight or 0) < TASK_BYTES for weight in weights)
        left -= sum(TASK_BYTES if weight is None else weight for weight in weights)


@pytest.mark.parametrize(
    ("sizes", "threads", "expected"),
    [
        (  # a thread's first alone, big and unknown alone, small ones packed up to
            # their share of the bytes left (half of them here) or the count
            [BIG + 1, None, MID, MID, MID, *[1_000] * 13],
            1,
            [1, 1, 1, 1, 1, 4, 4, 4, 1],
        ),
        (  # 26 logs fill a task's bytes; then a quarter of the bytes left, down to the
            # last tasks' bytes
            [SMALL] * 1000,
            2,
            [1, 1] + [26] * 35 + [22, 16, 12, 9, 7, 6, 6, 6, 4],
        ),
        ([1] * 1000, 2, [1, 1] + [125] * 7 + [123]),  # four tasks a thread, at least
        ([SMALL] * 3, 2, [1] * 3),  # too few to pack: every thread busy
        ([SMALL] * 1000, 160, [1] * 1000),
    ],
)
def test_big_dtcs_run_alone_and_small_ones_are_packed(
    sizes: list[int | None], threads: int, expected: list[int]
) -> None:
    assert [len(task) for task in tasks(sizes, threads)] == expected
