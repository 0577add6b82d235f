"""ROS 2 bags as DTC input: a bag imports as a session log with samples, and its DTC
replays at sensor level like a robot recording."""

from __future__ import annotations

import contextlib
import shutil
import sqlite3
from pathlib import Path

import msgspec
import pytest
from rosbags.rosbag2 import StoragePlugin

from beatlog.adapters.rosbag import BagImport, import_bag
from beatlog.analysis.summary import summarize
from beatlog.errors import BagError, LogExistsError, OptionError
from beatlog.log.reader import SessionLogReader
from beatlog.model.inbox import Sample
from beatlog.replay.verdict import DivergenceKind
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import load_spec
from tests.bags import (
    SONAR_EVERY_NS,
    START_NS,
    TICK_EVERY_NS,
    perceive,
    write_bag,
)
from tests.conftest import probe_system
from tests.specs import CHANGED, PROBE, write_spec

PERCEPTION = "tests.bags:perception"
CHECKING = "tests.bags:checking_perception"
LONG_RANGE = "tests.bags:long_range_perception"


def cycles_of(log: Path) -> list[tuple[int, list[Sample]]]:
    """Each cycle's heartbeat interval and samples, as the log holds them."""
    with SessionLogReader(log) as reader:
        return [
            (record.heartbeat_ns, msgspec.msgpack.decode(record.samples, type=list[Sample]))
            for record in reader.cycles()
        ]


def imported(tmp_path: Path, **options: object) -> BagImport:
    """The test bag imported with the probe system and the recorded perception step."""
    bag = tmp_path / "bag"
    if not bag.exists():
        write_bag(bag, ticks=95)
    settings: dict[str, object] = {"system": PROBE, "perception": PERCEPTION, **options}
    return import_bag(bag, tmp_path / "bag.beatlog", **settings)  # type: ignore[arg-type]


@pytest.mark.parametrize("storage", list(StoragePlugin))
def test_a_bag_with_a_message_type_of_its_own_imports_and_its_dtc_passes(
    tmp_path: Path, storage: StoragePlugin
) -> None:
    bag = write_bag(tmp_path / "sonar-run", storage=storage)
    spec = tmp_path / "dtc" / "sonar-run.dtc.toml"
    spec.parent.mkdir()

    result = import_bag(
        bag, tmp_path / "sonar-run.beatlog", system=PROBE, perception=CHECKING, spec=spec
    )

    assert result.topics == ("/sonar", "/speed")
    assert result.samples == 360
    assert result.spec == spec
    outcome = run_spec(load_spec(spec))
    assert outcome.verdict is Verdict.PASSED, outcome.result
    assert load_spec(spec).perception == CHECKING
    summary = summarize(result.log)
    assert summary.samples == {"/sonar": 300, "/speed": 60}
    assert summary.header.robot_id == "sonar-run"
    assert summary.header.start_time_ns == START_NS
    assert summary.header.software_version.startswith("ROS 2 bag")


def test_the_bag_file_itself_imports_as_its_folder_does(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    [storage_file] = bag.glob("*.db3")

    result = import_bag(
        storage_file, tmp_path / "file.beatlog", system=PROBE, perception=PERCEPTION
    )

    assert result.samples == 360


@pytest.mark.parametrize(
    ("system", "perception", "kind"),
    [
        (PROBE, LONG_RANGE, DivergenceKind.PERCEPTION),
        (CHANGED, PERCEPTION, DivergenceKind.STATE_CHANGES),
    ],
    ids=["changed perception", "changed system"],
)
def test_a_changed_perception_step_or_system_fails_the_dtc(
    tmp_path: Path, system: str, perception: str, kind: DivergenceKind
) -> None:
    log = imported(tmp_path).log
    spec = write_spec(tmp_path, "changed", log, system, perception=perception)

    outcome = run_spec(load_spec(spec))

    assert outcome.verdict is Verdict.FAILED
    assert outcome.result is not None
    assert outcome.result.divergence is not None
    assert outcome.result.divergence.kind is kind


def test_by_period_each_heartbeat_takes_the_messages_of_its_period(tmp_path: Path) -> None:
    result = imported(tmp_path, period_ns=20_000_000, topics=["/sonar"])

    cycles = cycles_of(result.log)
    assert result.cycles == len(cycles) == 150  # 300 sonars, 10 ms apart
    assert result.robot_time_ns == 150 * 20_000_000
    assert {interval for interval, _ in cycles} == {20_000_000}
    for index, (_, samples) in enumerate(cycles):
        assert [sample.stamp_ns for sample in samples] == [
            START_NS + (2 * index + offset) * SONAR_EVERY_NS for offset in (0, 1)
        ]


def test_by_clock_topic_each_message_on_it_is_a_heartbeat(tmp_path: Path) -> None:
    result = imported(tmp_path, clock_topic="/tick", topics=["/sonar"])

    cycles = cycles_of(result.log)
    assert result.cycles == len(cycles) == 94  # one fewer than the ticks: their intervals
    assert {interval for interval, _ in cycles} == {TICK_EVERY_NS}
    first_tick = START_NS + TICK_EVERY_NS
    assert [sample.stamp_ns for sample in cycles[0][1]] == [
        START_NS + index * SONAR_EVERY_NS
        for index in range(7)  # before the 2nd tick too
    ]
    assert max(sample.stamp_ns for sample in cycles[1][1]) == first_tick + 2 * TICK_EVERY_NS
    last_tick = first_tick + 94 * TICK_EVERY_NS
    folded = sum(len(samples) for _, samples in cycles)
    assert (
        result.left_out
        == 300 - folded
        == (START_NS + 299 * SONAR_EVERY_NS - last_tick) // (SONAR_EVERY_NS)
    )
    assert summarize(result.log).header.period_ns == TICK_EVERY_NS


def test_the_clock_topic_messages_are_samples_when_its_topic_is_imported(tmp_path: Path) -> None:
    result = imported(tmp_path, clock_topic="/tick")

    assert result.topics == ("/sonar", "/speed", "/tick")
    assert summarize(result.log).samples is not None
    assert summarize(result.log).samples["/tick"] == 95  # type: ignore[index]


def test_the_import_replays_what_the_system_did_on_the_perceived_states(tmp_path: Path) -> None:
    result = imported(tmp_path)
    state = None
    with SessionLogReader(result.log) as reader:
        records = list(reader.cycles())
    for interval, samples in cycles_of(result.log):
        assert interval == 30_000_000
        state = perceive(state, samples)
    assert bytes(records[-1].robot_state) == msgspec.msgpack.encode(state)


@pytest.mark.parametrize(
    ("options", "problem"),
    [
        (
            {"topics": ["/sonar", "/camera"]},
            "no topic '/camera' (the bag has: /sonar, /speed, /tick)",
        ),
        ({"clock_topic": "/clock"}, "no topic '/clock'"),
        ({"perception": "tests.bags:broken_perception"}, "the perception step raised ValueError"),
        ({"perception": "tests.bags:wrong_perception"}, "built a dict, not a Probe"),
    ],
)
def test_what_cannot_be_imported_is_a_bag_error_naming_the_bag(
    tmp_path: Path, options: dict[str, object], problem: str
) -> None:
    with pytest.raises(BagError, match=r"^.*bag: .*") as raised:
        imported(tmp_path, **options)

    assert problem in str(raised.value)
    assert not (tmp_path / "bag.beatlog").exists()  # whole or not at all


def test_a_failing_perception_names_the_cycle_and_keeps_the_users_traceback(
    tmp_path: Path,
) -> None:
    with pytest.raises(BagError) as raised:
        imported(tmp_path, perception="tests.bags:broken_perception")

    assert "cycle 13: the perception step raised ValueError: sonar blinded" in str(raised.value)
    assert raised.value.user_traceback is not None
    assert "tests/bags.py" in raised.value.user_traceback


def test_a_clock_topic_needs_two_messages(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag", ticks=1)

    with pytest.raises(BagError, match="clock topic '/tick' has 1 message times"):
        imported(tmp_path, clock_topic="/tick")


def test_a_bag_without_messages_on_the_topics_asked_for_is_refused(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag", sonars=0)

    with pytest.raises(BagError, match="no messages on /sonar"):
        imported(tmp_path, topics=["/sonar"])


@pytest.mark.parametrize("what", ["missing", "not a bag", "truncated"])
def test_a_missing_or_damaged_bag_is_a_bag_error(tmp_path: Path, what: str) -> None:
    bag = tmp_path / "bag"
    if what == "not a bag":
        bag.write_text("hello")
    elif what == "truncated":
        write_bag(tmp_path / "whole")
        shutil.copytree(tmp_path / "whole", bag)
        [data] = bag.glob("*.mcap")
        data.write_bytes(data.read_bytes()[:-200])

    with pytest.raises(BagError) as raised:
        import_bag(bag, tmp_path / "out.beatlog", system=PROBE, perception=PERCEPTION)

    assert str(raised.value).startswith(f"{bag}: ")
    assert not (tmp_path / "out.beatlog").exists()


@pytest.mark.parametrize(
    ("options", "problem"),
    [
        ({"period_ns": 0}, "must be positive"),
        ({"period_ns": 10, "clock_topic": "/tick"}, "not both"),
        ({"spec": "x.dtc.toml", "perception": perceive}, "give module:factory"),
    ],
)
def test_options_that_do_not_fit_are_refused_before_anything_is_read(
    tmp_path: Path, options: dict[str, object], problem: str
) -> None:
    with pytest.raises(OptionError, match=problem):
        imported(tmp_path, **options)


def test_an_import_never_replaces_a_log_unless_asked(tmp_path: Path) -> None:
    first = imported(tmp_path)

    with pytest.raises(LogExistsError):
        imported(tmp_path)
    assert imported(tmp_path, overwrite=True).cycles == first.cycles


def test_system_and_perception_may_be_objects(tmp_path: Path) -> None:
    result = imported(tmp_path, system=probe_system(), perception=perceive)

    assert result.cycles == 100
    assert summarize(result.log).header.system == ""


def test_a_bag_without_type_definitions_imports_the_standard_types_it_uses(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    [database] = bag.glob("*.db3")
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute("DELETE FROM message_definitions")  # as bags before ROS 2 Iron

    with pytest.raises(BagError, match="does not define message type my_robot_msgs/msg/Sonar"):
        imported(tmp_path)
    assert imported(tmp_path, topics=["/speed"]).samples == 60
