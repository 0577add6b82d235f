"""The log tests' fixture: a log in many small chunks, read whole once a module."""

from __future__ import annotations

import pytest
from mcap.opcode import Opcode

from beatlog.log.reader import LogStatus
from tests.crafting import (
    CYCLES,
    CYCLES_PER_CHUNK,
    Original,
    chunks,
    encoded,
    read_all,
    top_level_records,
    write_chunked_log,
)


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> Original:
    path = write_chunked_log(tmp_path_factory.mktemp("original") / "chunked.beatlog")
    data = path.read_bytes()
    cycles, status = read_all(path)
    assert status == LogStatus(complete=True, cycles=len(cycles))
    assert len(cycles) == CYCLES
    all_chunks = chunks(data)
    assert len(all_chunks) == 1 + CYCLES // CYCLES_PER_CHUNK + 1, "header, cycles, end"
    [footer] = [r for r in top_level_records(data) if r.opcode == Opcode.FOOTER]
    return Original(data, encoded(cycles), all_chunks[0].end, all_chunks[1:-1], footer)
