"""Baseline files: a text format that diffs cleanly, reads back exactly, and never runs code."""

from __future__ import annotations

import dataclasses
import struct
import tracemalloc
from collections.abc import Callable, Iterator
from pathlib import Path

import msgspec
import pytest
import zstandard

from beatlog.baseline.file import (
    expected_path,
    log_digest,
    pending_path,
    read_baseline,
    text_blocks,
)
from beatlog.baseline.write import format_lines, write_baseline
from beatlog.errors import BaselineError
from beatlog.replay.approved_states import ApprovedStates
from beatlog.replay.baseline import (
    ABSENT,
    AS_RECORDED,
    Baseline,
    TracedOutput,
    TracedStateChange,
)
from beatlog.replay.verdict import StateChange
from tests.factories import rebuilt_states, speed_state
from tests.specs import baseline_file

CHANGES = (
    TracedStateChange(0, 30_000_000, StateChange("arbiter", "idle", "wander")),
    TracedStateChange(12, 360_012_000, StateChange("avoid", "off", "turning")),
    TracedStateChange(12, 360_012_000, StateChange('odd "name": ->', 3, None)),
    TracedStateChange(4001, 120_030_000_000, StateChange("dock ü", True, False)),
)


@pytest.fixture
def log(tmp_path: Path) -> Path:
    path = tmp_path / "session.beatlog"
    path.write_bytes(b"a recording")
    return path


def baseline_of(log: Path, path: Path, baseline: Baseline) -> Path:
    """``baseline`` written to ``path`` as the baseline of spec ``a``, recorded as ``log``."""
    write_baseline(
        path, spec_name="a", log_name=log.name, digest=log_digest(log), baseline=baseline
    )
    return path


def test_a_baseline_reads_back_what_was_written(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.expected"
    baseline_of(log, path, Baseline(CHANGES, ()))

    baseline = read_baseline(path)

    assert baseline.log_digest == log_digest(log)
    assert [(c.cycle, c.change) for c in baseline.whole.changes] == [
        (c.cycle, c.change) for c in CHANGES
    ]
    assert [c.time_ns for c in baseline.whole.changes] == [
        30_000_000,
        360_000_000,
        360_000_000,
        120_030_000_000,
    ]
    assert (baseline.whole.changes_override() or {})[12] == [CHANGES[1].change, CHANGES[2].change]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.dtc.expected", "session.beatlog"]


def test_a_baseline_is_one_readable_line_per_state_change(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.pending"
    baseline_of(log, path, Baseline(CHANGES[:2], ()))

    lines = path.read_text(encoding="utf-8").splitlines()

    assert lines[0] == "# beatlog expected departures from the recording, format 7"
    assert lines[2] == f"# log session.beatlog sha256 {log_digest(log)}"
    assert lines[-2:] == [
        '       0     0.030  "arbiter": "idle" -> "wander"',
        '      12     0.360  "avoid": "off" -> "turning"',
    ]


def test_an_empty_baseline_is_valid(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.expected"
    baseline_of(log, path, Baseline((), ()))
    assert read_baseline(path).whole.changes == ()


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", "not a beatlog baseline (its first line is not the header)"),
        ("cycle,behavior\n1,a\n", "not a beatlog baseline (its first line is not the header)"),
        (
            "# beatlog expected departures from the recording, format 7\n",
            "no '# log NAME sha256 DIGEST' line",
        ),
        (
            "HEADER\n  7  0.210  avoid: 1 -> 2\n",
            "line 5: Expecting value: line 1 column 1 (char 0)",
        ),
        ('HEADER\n  7  0.210  "avoid" 1 -> 2\n', "line 5: expected ':' at column 8"),
        ('HEADER\n  7  0.210  "avoid": 1 => 2\n', "line 5: expected '->' at column 11"),
        (
            'HEADER\n  7  0.210  "avoid": 1 -> 2 -> 3\n',
            "line 5: unexpected ' -> 3' after the state",
        ),
        (
            'HEADER\n  7  0.210  "a": {"__class__": "os.system"} -> 2\n',
            "line 5: a state must be a string, number, flag or null, "
            "not {'__class__': 'os.system'}",
        ),
        (
            'HEADER\n  7  0.210  "a": [1] -> 2\n',
            "line 5: a state must be a string, number, flag or null, not [1]",
        ),
        ("HEADER\n  7  0.210  3: 1 -> 2\n", "line 5: the behavior must be a JSON string"),
        (
            'HEADER\n  x  0.210  "a": 1 -> 2\n',
            "line 5: expected 'CYCLE TIME \"behavior\": BEFORE -> AFTER', "
            "'CYCLE TIME output \"field\" = VALUE' or 'CYCLE TIME robot_state ...'",
        ),
    ],
)
def test_a_damaged_or_foreign_baseline_is_an_error_naming_file_and_line(
    tmp_path: Path, text: str, problem: str
) -> None:
    header = (
        "# beatlog expected departures from the recording, format 7\n# spec a\n"
        f"# log a.beatlog sha256 {'0' * 64}\n# comment"
    )
    path = tmp_path / "a.dtc.expected"
    path.write_text(text.replace("HEADER", header), encoding="utf-8")

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value) == f"{path}: {problem}"


def test_a_missing_baseline_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(BaselineError, match="no such file"):
        read_baseline(tmp_path / "gone.dtc.expected")


def test_baseline_files_sit_beside_their_spec() -> None:
    spec = Path("specs/avoid-pole.dtc.toml")
    assert expected_path(spec) == Path("specs/avoid-pole.dtc.expected")
    assert pending_path(spec) == Path("specs/avoid-pole.dtc.pending")


def _bits(value: object) -> bytes:
    return msgspec.msgpack.Encoder(order="sorted").encode(value)


NEGATIVE_NAN = struct.unpack("<d", struct.pack("<Q", 0xFFF8_0000_0000_0000))[0]
PAYLOAD_NAN = struct.unpack("<d", struct.pack("<Q", 0x7FF8_0000_0000_0001))[0]


@pytest.mark.parametrize(
    ("value", "written"),
    [
        (0.1, "0.1"),
        (-0.0, "-0.0"),
        (1e-310, "1e-310"),
        (float("nan"), "NaN"),
        (float("inf"), "Infinity"),
        (float("-inf"), "-Infinity"),
        (NEGATIVE_NAN, "msgpack:cbfff8000000000000"),
        (PAYLOAD_NAN, "msgpack:cb7ff8000000000001"),
        (3, "3"),
        (True, "true"),
        (None, "null"),
        ("ü", '"\\u00fc"'),
        ([0.5, -0.0, [1]], "[0.5, -0.0, [1]]"),
        ({"b": 1, "a": [2.5]}, '{"a": [2.5], "b": 1}'),
        (b"\x00\xff", "msgpack:c40200ff"),
    ],
    ids=repr,
)
def test_an_output_value_reads_back_bit_for_bit(
    tmp_path: Path, log: Path, value: object, written: str
) -> None:
    path = tmp_path / "a.dtc.expected"
    outputs = (TracedOutput(5, 180_000_000, "motor", value),)
    baseline_of(log, path, Baseline((), outputs))

    assert path.read_text(encoding="utf-8").splitlines()[-1] == (
        f'       5     0.180  output "motor" = {written}'
    )
    (traced,) = read_baseline(path).whole.outputs or ()
    assert (traced.cycle, traced.field) == (5, "motor")
    assert _bits(traced.value) == _bits(value)


def test_output_changes_interleave_with_state_changes_by_cycle(tmp_path: Path, log: Path) -> None:
    path = tmp_path / "a.dtc.pending"
    outputs = (
        TracedOutput(0, 30_000_000, "speed", 0.5),
        TracedOutput(12, 360_012_000, "speed", 0.0),
        TracedOutput(13, 390_000_000, "speed", ABSENT),
    )
    baseline_of(log, path, Baseline(CHANGES[:2], outputs))

    lines = path.read_text(encoding="utf-8").splitlines()

    assert lines[-5:] == [
        '       0     0.030  "arbiter": "idle" -> "wander"',
        '       0     0.030  output "speed" = 0.5',
        '      12     0.360  "avoid": "off" -> "turning"',
        '      12     0.360  output "speed" = 0.0',
        '      13     0.390  output "speed" absent',
    ]
    baseline = read_baseline(path)
    assert baseline.whole.outputs is not None
    assert [(o.cycle, o.field, o.value) for o in baseline.whole.outputs] == [
        (0, "speed", 0.5),
        (12, "speed", 0.0),
        (13, "speed", ABSENT),
    ]


def test_pinned_robot_states_come_first_in_their_cycle_and_read_back(
    tmp_path: Path, log: Path
) -> None:
    path = tmp_path / "a.dtc.pending"
    states = {cycle: speed_state(cycle) for cycle in (12, 13, 16)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    outputs = (TracedOutput(12, 12_000_000, "speed", 0.0),)
    changes = (TracedStateChange(12, 12_000_000, StateChange("avoid", "off", "turning")),)
    expectation = Baseline(changes, outputs, approved_states=approved)
    baseline_of(log, path, expectation)

    lines = path.read_text(encoding="utf-8").splitlines()

    assert lines[3].endswith("| robot_state digests N DIGEST TAGS")
    assert lines[-4:] == [
        "      12     0.012  robot_state otherwise in 12..16 (3 cycles): "
        '["speed"], first {"speed": 0.012}',
        "      12     0.012  robot_state digests 5 45b024220a80a3e9 Zsc2....aF",
        '      12     0.012  "avoid": "off" -> "turning"',
        '      12     0.012  output "speed" = 0.0',
    ]
    baseline = read_baseline(path)
    assert baseline.whole.approved_states == approved


def test_a_baselines_robot_states_read_back_pinned_by_their_digests(
    tmp_path: Path,
) -> None:
    states = {cycle: speed_state(cycle) for cycle in (12, 13, 16, 40)}
    approved = ApprovedStates.from_rebuilt(rebuilt_states(states))
    path = baseline_file(tmp_path, 7, *format_lines((), (), approved_states=approved))

    assert read_baseline(path).whole.approved_states == approved


RUN = "robot_state otherwise in 7..7 (1 cycle)"
NO_STATE_LINE = (
    "line 4: expected 'robot_state otherwise in FIRST..LAST (N cycles): [FIELDS], "
    "first {VALUES}' or 'robot_state digests N DIGEST TAGS'"
)
"""What a baseline says of a robot-state line of neither of its shapes."""


@pytest.mark.parametrize(
    ("magic", "line", "problem"),
    [
        (7, "  7  0.210  output speed = 1", "line 4: Expecting value: line 1 column 1 (char 0)"),
        (7, "  7  0.210  output 3 = 1", "line 4: the field must be a JSON string"),
        (7, '  7  0.210  output "speed" 1', "line 4: expected '=' at column 8"),
        (7, '  7  0.210  output "speed" = 1 2', "line 4: unexpected ' 2' after the value"),
        (
            7,
            '  7  0.210  output "speed" = msgpack:zz',
            "line 4: a damaged msgpack value: "
            "non-hexadecimal number found in fromhex() arg at position 0",
        ),
        (
            7,
            '  7  0.210  output "speed" = msgpack:c1',
            "line 4: a damaged msgpack value: "
            "MessagePack data is malformed: invalid opcode '\\xc1' (byte 0)",
        ),
        (7, '  7  0.210  sensor "x" = 1', "line 4: Expecting value: line 1 column 1 (char 0)"),
        (7, '  7  0.210  robot_state "x" = 1', NO_STATE_LINE),
        (7, "  7  0.210  robot_state digests 1 00 AA", NO_STATE_LINE),
        (
            7,
            "  7  0.210  robot_state digests 1 0000000000000000 A",
            "line 4: expected 2 characters of tags, found 1",
        ),
        (
            7,
            "  7  0.210  robot_state digests 2 000000000000000f AA",
            "line 4: expected 4 characters of tags, found 2",
        ),
        (
            7,
            f"  7  0.210  {RUN}: [1], first {{}}",
            "line 4: the fields must be a JSON list of strings",
        ),
        (7, f'  7  0.210  {RUN}: ["x"] first {{}}', "line 4: expected ', first' at column 6"),
        (
            7,
            f'  7  0.210  {RUN}: ["x"], first [1]',
            "line 4: the first cycle's values must be a JSON object",
        ),
        (
            7,
            f'  7  0.210  {RUN}: ["x"], first {{"x": 1}} 2',
            "line 4: unexpected ' 2' after the value",
        ),
        (
            7,
            f'  8  0.210  {RUN}: ["x"], first {{"x": 1}}',
            "line 4: a run of cycles from 7 on a line of cycle 8",
        ),
        (
            7,
            f'  7  0.210  {RUN}: ["x"], first {{"x": 1}}',
            "the robot-state run from cycle 7 has digests that do not end at its last cycle, 7",
        ),
    ],
)
def test_a_damaged_output_line_is_an_error_naming_file_and_line(
    tmp_path: Path, magic: int, line: str, problem: str
) -> None:
    path = baseline_file(tmp_path, magic, "#", line)

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value) == f"{path}: {problem}"


def test_departures_read_back_with_quiet_cycles_and_outputs_as_recorded_again(
    tmp_path: Path, log: Path
) -> None:
    path = tmp_path / "a.dtc.pending"
    outputs = (
        TracedOutput(12, 360_012_000, "speed", 0.0),
        TracedOutput(13, 390_000_000, "turn", ABSENT),
        TracedOutput(20, 600_000_000, "speed", AS_RECORDED),
    )
    baseline = Baseline(
        CHANGES[1:2],
        outputs,
        open_loop=(12, 360_012_000),
        quiet=((15, 450_000_000),),
    )
    baseline_of(log, path, baseline)

    assert path.read_text(encoding="utf-8").splitlines()[-6:] == [
        "      12     0.360  open loop",
        '      12     0.360  "avoid": "off" -> "turning"',
        '      12     0.360  output "speed" = 0.0',
        '      13     0.390  output "turn" absent',
        "      15     0.450  no state changes",
        '      20     0.600  output "speed" as recorded',
    ]
    read = read_baseline(path).whole
    assert read == dataclasses.replace(
        baseline,
        changes=(CHANGES[1]._replace(time_ns=360_000_000),),
        open_loop=(12, 360_000_000),
        outputs=(outputs[0]._replace(time_ns=360_000_000), *outputs[1:]),
    )
    assert read.changes_override() == {12: [CHANGES[1].change], 15: []}
    assert not read.as_recorded


@pytest.mark.parametrize(
    ("version", "lines", "problem"),
    [
        (
            7,
            ['  13  0.390  output "speed" = 1.0', '  12  0.360  output "speed" = 2.0'],
            "output lines are not in cycle order",
        ),
        (
            7,
            ['  12  0.360  "avoid": "off" -> "turning"', "  12  0.360  no state changes"],
            "cycle 12 has state changes and none",
        ),
    ],
    ids=["outputs out of order", "both"],
)
def test_a_baseline_that_breaks_its_formats_rules_is_an_error(
    tmp_path: Path, version: int, lines: list[str], problem: str
) -> None:
    with pytest.raises(BaselineError, match=problem):
        read_baseline(baseline_file(tmp_path, version, *lines))


def _big_baseline(folder: Path, cycles: int) -> Path:
    """A baseline departing in every cycle: two outputs, and a state change in
    every third cycle."""
    lines = ["      12     0.360  open loop"]
    for cycle in range(12, 12 + cycles):
        time = f"{cycle * 0.03:.3f}"
        lines.append(f'{cycle:8d}  {time:>8}  output "speed" = {cycle / 7!r}')
        lines.append(f'{cycle:8d}  {time:>8}  output "turn" = {cycle % 5}')
        if cycle % 3 == 0:
            lines.append(f'{cycle:8d}  {time:>8}  "avoid": "idle" -> "turning"')
    return baseline_file(folder, 7, *lines, name=f"big{cycles}")


def _peak(read: Callable[[], object]) -> int:
    """The most memory ``read`` held at once, in bytes."""
    tracemalloc.start()
    try:
        read()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak


def _every_line(path: Path) -> int:
    """How many output lines replay reads of the baseline at ``path``, as it reads them."""
    return sum(len(part.outputs) for part in read_baseline(path).stream.parts())


def test_a_big_baseline_is_read_in_memory_that_does_not_grow_with_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.baseline.file.BLOCK_BYTES", 4096)
    small, large = _big_baseline(tmp_path, 1_000), _big_baseline(tmp_path, 4_000)
    assert large.stat().st_size > 3 * small.stat().st_size

    checked = _peak(lambda: read_baseline(large)) - _peak(lambda: read_baseline(small))
    assert checked < 64 * 1024, "reading keeps more than a block"
    assert _every_line(large) == 8_000
    replayed = _peak(lambda: _every_line(large)) - _peak(lambda: _every_line(small))
    assert replayed < 64 * 1024, "replay reads more than a block at a time"


def test_an_error_after_the_first_block_names_its_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.baseline.file.BLOCK_BYTES", 64)
    lines = [f'{cycle:8d}  {cycle * 0.03:8.3f}  output "speed" = {cycle}' for cycle in range(40)]
    path = baseline_file(tmp_path, 7, *lines, f'      40  {1.2:8.3f}  output "speed" = x', "")

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value) == f"{path}: line 43: Expecting value: line 1 column 1 (char 0)"


def test_a_line_of_an_earlier_cycle_than_a_block_before_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.baseline.file.BLOCK_BYTES", 64)
    lines = [f'{cycle:8d}  {cycle * 0.03:8.3f}  output "speed" = {cycle}' for cycle in range(40)]
    path = baseline_file(tmp_path, 7, *lines, f'      12  {0.36:8.3f}  "avoid": "off" -> "on"')

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value) == f"{path}: the lines of cycle 12 are not in cycle order"


def test_the_lines_of_a_big_baseline_share_their_names_and_cycles(tmp_path: Path) -> None:
    baseline = read_baseline(_big_baseline(tmp_path, 300)).whole
    outputs, changes = baseline.outputs or (), baseline.changes

    assert all(output.field is outputs[0].field for output in outputs[::2])
    assert all(output.time_ns is outputs[0].time_ns for output in outputs[:2])
    assert all(change.change.after is changes[0].change.after for change in changes)


@pytest.mark.parametrize("version", [1, 2, 3, 4, 5, 6])
def test_an_older_baseline_is_refused_naming_the_command_that_upgrades_it(
    tmp_path: Path, version: int
) -> None:
    path = baseline_file(tmp_path, version, '      12     0.360  "avoid": "off" -> "turning"')

    with pytest.raises(BaselineError) as raised:
        read_baseline(path)

    assert str(raised.value) == (
        f"{path}: a format {version} baseline: "
        f"run 'beatlog upgrade-baselines {path}' to rewrite it in format 7"
    )


def test_a_baseline_changed_after_it_was_read_is_an_error_when_replay_reads_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.baseline.file.BLOCK_BYTES", 64)  # read again past a block
    path = baseline_file(tmp_path, 7, '      12     0.360  "avoid": "off" -> "turning"')
    baseline = read_baseline(path)
    baseline_file(tmp_path, 7, '      12     0.360  "escape": "off" -> "on"')

    with pytest.raises(BaselineError) as raised:
        list(baseline.stream.parts())

    assert str(raised.value) == f"{path}: changed while it was read: run again"


def test_a_baseline_of_one_block_is_read_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _big_baseline(tmp_path, 10)
    opened: list[Path] = []

    def counted(path: Path) -> Iterator[str]:
        opened.append(path)
        return text_blocks(path)

    monkeypatch.setattr("beatlog.baseline.file.text_blocks", counted)
    baseline = read_baseline(path)
    replayed = [line for part in baseline.stream.parts() for line in part.outputs]

    assert len(replayed) == 20
    assert replayed == list(baseline.whole.outputs)
    assert opened == [path]


@pytest.fixture
def small_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Baselines read 64 bytes at a time."""
    monkeypatch.setattr("beatlog.baseline.file.BLOCK_BYTES", 64)


def test_a_zstd_frame_is_read_as_the_text_it_holds_a_block_at_a_time(
    tmp_path: Path, small_blocks: None
) -> None:
    text = "".join(f"line {n}\n" for n in range(100))
    path = tmp_path / "a.dtc.expected"
    path.write_bytes(zstandard.ZstdCompressor().compress(text.encode()))

    assert "".join(text_blocks(path)) == text


def test_damaged_zstd_data_is_an_error_naming_the_file(tmp_path: Path, small_blocks: None) -> None:
    path = tmp_path / "a.dtc.expected"
    path.write_bytes(zstandard.ZstdCompressor().compress(b"line\n" * 100)[:-8] + bytes(8))

    with pytest.raises(BaselineError, match=r"a.dtc.expected: cannot read: damaged zstd data"):
        "".join(text_blocks(path))


def test_a_small_zstd_frame_of_too_much_text_is_refused_as_it_is_read(
    tmp_path: Path, small_blocks: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("beatlog.baseline.file.MAX_BASELINE_BYTES", 10_000)
    path = tmp_path / "a.dtc.expected"
    path.write_bytes(zstandard.ZstdCompressor().compress(b"0" * 100_000))

    assert path.stat().st_size < 1_000
    with pytest.raises(BaselineError) as raised:
        "".join(text_blocks(path))

    assert str(raised.value) == f"{path}: holds more than 10000 bytes of text; not a baseline"
