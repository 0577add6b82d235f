"""A log read once: hashed as it streams, kept for the readers after it."""

from __future__ import annotations

import hashlib
import os
import pickle
from pathlib import Path

from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.log.recording import Recording
from tests.crafting import Original, encoded, read_all, write


def test_a_read_to_the_end_takes_the_digest_of_every_byte_and_keeps_them(
    tmp_path: Path, original: Original
) -> None:
    path = write(tmp_path / "a.beatlog", original.data)
    recording = Recording(path)

    read_all(recording)

    assert recording.digest == hashlib.sha256(original.data).hexdigest()
    assert recording.data == original.data


def test_readers_after_the_first_read_the_kept_bytes_not_the_file(
    tmp_path: Path, original: Original
) -> None:
    path = write(tmp_path / "a.beatlog", original.data)
    recording = Recording(path)
    read_all(recording)
    path.unlink()

    cycles, status = read_all(recording)

    assert encoded(cycles) == original.cycles
    assert status == LogStatus(complete=True, cycles=len(cycles))


def test_a_log_larger_than_the_bound_is_hashed_but_not_kept(
    tmp_path: Path, original: Original
) -> None:
    path = write(tmp_path / "a.beatlog", original.data)
    recording = Recording(path, keep=len(original.data) - 1)

    read_all(recording)

    assert recording.digest == hashlib.sha256(original.data).hexdigest()
    assert recording.data is None


def test_a_log_cut_off_is_hashed_and_kept_whole(tmp_path: Path, original: Original) -> None:
    cut = original.data[: len(original.data) // 2]
    recording = Recording(write(tmp_path / "a.beatlog", cut))
    cycles, status = read_all(recording)

    again = read_all(recording)

    assert not status.complete
    assert (recording.digest, recording.data) == (hashlib.sha256(cut).hexdigest(), cut)
    assert (encoded(again[0]), again[1]) == (encoded(cycles), status)


def test_a_read_that_stops_short_of_the_end_takes_no_digest(
    tmp_path: Path, original: Original
) -> None:
    recording = Recording(write(tmp_path / "a.beatlog", original.data))

    with SessionLogReader(recording) as reader:
        next(reader.batches())

    assert (recording.digest, recording.data) == (None, None)


def test_a_recording_stands_for_its_path_and_travels_without_a_read_under_way(
    tmp_path: Path, original: Original
) -> None:
    path = write(tmp_path / "a.beatlog", original.data)
    recording = Recording(path)
    recording.start()

    copy = pickle.loads(pickle.dumps(recording))

    assert (os.fspath(recording), str(recording), Path(recording)) == (str(path), str(path), path)
    assert (copy.path, copy.digest, copy.data) == (path, None, None)
