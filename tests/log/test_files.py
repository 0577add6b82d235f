"""The files users name: read only when regular, so nothing read can block, and written
whole or not at all."""

from __future__ import annotations

import os
import socket
from pathlib import Path

import pytest

from beatlog.errors import SpecError
from beatlog.log.files import (
    Closing,
    irregular_file_problem,
    read_small_text,
    replacing,
)


def test_a_regular_file_has_no_problem(tmp_path: Path) -> None:
    path = tmp_path / "probe.beatlog"
    path.write_bytes(b"")

    assert irregular_file_problem(path) is None


def test_a_missing_file_is_no_such_file(tmp_path: Path) -> None:
    assert irregular_file_problem(tmp_path / "lost.beatlog") == "no such file"


def test_a_directory_is_a_directory(tmp_path: Path) -> None:
    assert irregular_file_problem(tmp_path) == "is a directory"


def test_a_fifo_is_refused_before_anything_opens_it(tmp_path: Path) -> None:
    fifo = tmp_path / "session.beatlog"
    os.mkfifo(fifo)

    assert irregular_file_problem(fifo) == "is not a regular file (a FIFO, socket or device)"


def test_a_socket_is_refused_too(tmp_path: Path) -> None:
    path = tmp_path / "s"
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(path))

        assert irregular_file_problem(path) == "is not a regular file (a FIFO, socket or device)"


def test_a_symlink_to_a_regular_file_is_regular(tmp_path: Path) -> None:
    target = tmp_path / "probe.beatlog"
    target.write_bytes(b"x")
    link = tmp_path / "latest.beatlog"
    link.symlink_to(target)

    assert irregular_file_problem(link) is None


def test_replacing_writes_the_new_file_whole_when_the_block_ends(tmp_path: Path) -> None:
    path = tmp_path / "report.xml"
    path.write_bytes(b"old")

    with replacing(path) as file:
        file.write(b"new, ")
        assert path.read_bytes() == b"old"  # readers see the old file until the end
        file.write(b"whole")

    assert path.read_bytes() == b"new, whole"
    assert sorted(tmp_path.iterdir()) == [path]


def test_replacing_creates_a_file_that_did_not_exist(tmp_path: Path) -> None:
    path = tmp_path / "report.html"

    with replacing(path) as file:
        file.write(b"<html>")

    assert path.read_bytes() == b"<html>"


@pytest.mark.parametrize("interruption", [RuntimeError("the chart failed"), KeyboardInterrupt()])
def test_replacing_leaves_the_old_file_and_no_litter_when_the_block_raises(
    tmp_path: Path, interruption: BaseException
) -> None:
    path = tmp_path / "report.xml"
    path.write_bytes(b"old")

    def write_half() -> None:
        with replacing(path) as file:
            file.write(b"half of the new")
            raise interruption

    with pytest.raises(type(interruption)):
        write_half()

    assert path.read_bytes() == b"old"
    assert sorted(tmp_path.iterdir()) == [path]


def read_spec(path: Path) -> str:
    return read_small_text(path, limit=8, kind="DTC spec", error=SpecError)


def test_a_small_text_file_is_read_whole(tmp_path: Path) -> None:
    path = tmp_path / "a.dtc.toml"
    path.write_text("name = 1", encoding="utf-8")

    assert read_spec(path) == "name = 1"


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b"name = 12", "is larger than 8 bytes; not a DTC spec"),
        (
            b"\xff\xfe",
            "cannot read: 'utf-8' codec can't decode byte 0xff in position 0: invalid start byte",
        ),
    ],
)
def test_a_small_text_file_too_large_or_not_utf8_is_the_error_asked_for(
    tmp_path: Path, content: bytes, problem: str
) -> None:
    path = tmp_path / "a.dtc.toml"
    path.write_bytes(content)

    with pytest.raises(SpecError) as raised:
        read_spec(path)

    assert (raised.value.path, raised.value.problem) == (path, problem)


def test_a_small_text_file_that_is_not_regular_is_refused_unopened(tmp_path: Path) -> None:
    fifo = tmp_path / "a.dtc.toml"
    os.mkfifo(fifo)

    with pytest.raises(SpecError) as raised:
        read_spec(fifo)

    assert str(raised.value) == f"{fifo}: is not a regular file (a FIFO, socket or device)"


class Held(Closing):
    def __init__(self) -> None:
        self.closed = 0

    def close(self) -> None:
        self.closed += 1


def test_the_block_gets_the_object_and_closes_it() -> None:
    with Held() as held:
        assert held.closed == 0
    assert held.closed == 1


def test_a_block_that_raises_still_closes_and_the_error_goes_on() -> None:
    held = Held()
    with pytest.raises(ValueError, match="boom"), held:
        raise ValueError("boom")
    assert held.closed == 1
