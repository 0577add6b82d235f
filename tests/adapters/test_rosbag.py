"""ROS 2 bags as DTC input: a bag imports as a session log with samples, and its DTC
replays at sensor level like a robot recording."""

from __future__ import annotations

import contextlib
import inspect
import re
import shutil
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import msgspec
import pytest
from rosbags.rosbag2 import StoragePlugin

from beatlog.adapters import rosbag
from beatlog.adapters.rosbag import BagImport, import_bag
from beatlog.analysis.summary import summarize
from beatlog.errors import BagError, LogExistsError, OptionError, SpecError
from beatlog.log.reader import SessionLogReader
from beatlog.model.inbox import Sample
from beatlog.replay.verdict import DivergenceKind
from beatlog.suite.runner import Verdict, run_spec
from beatlog.suite.spec import load_spec
from tests.bags import (
    LOG_EVERY_NS,
    LOGS_FROM_NS,
    SONAR_EVERY_NS,
    SPEED,
    START_NS,
    TICK_EVERY_NS,
    broken_perception,
    edit_metadata,
    flip_bit,
    name_other_qos,
    perceive,
    storage_file,
    write_bag,
)
from tests.conftest import probe_system
from tests.specs import CHANGED, PROBE, write_spec
from tests.text import frames

PERCEPTION = "tests.bags:perception"
CHECKING = "tests.bags:checking_perception"
LONG_RANGE = "tests.bags:long_range_perception"
MISMATCH = "the bag is damaged, or its metadata.yaml does not match its storage files"
"""How a folder's counts that do not add up end."""


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


def test_a_system_drawing_at_set_up_imports_with_its_set_up_draws(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "sonar-run", storage=StoragePlugin.SQLITE3)
    spec = tmp_path / "sonar-run.dtc.toml"

    result = import_bag(
        bag,
        tmp_path / "sonar-run.beatlog",
        system="tests.systems:driver_system",
        perception=CHECKING,
        spec=spec,
    )

    assert len(summarize(result.log).header.drawn_at_setup()) == 2
    assert run_spec(load_spec(spec)).verdict is Verdict.PASSED


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


def test_by_period_the_heartbeats_start_at_the_first_message_imported(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag", logs=10)  # /rosout begins a second after the bag

    result = imported(tmp_path, period_ns=LOG_EVERY_NS, topics=["/rosout"])

    assert [[sample.stamp_ns for sample in samples] for _, samples in cycles_of(result.log)] == [
        [LOGS_FROM_NS + index * LOG_EVERY_NS] for index in range(10)
    ]
    assert result.robot_time_ns == 10 * LOG_EVERY_NS
    assert summarize(result.log).header.start_time_ns == LOGS_FROM_NS


def test_a_message_is_its_fields_not_its_types_constants(tmp_path: Path) -> None:
    write_bag(tmp_path / "bag", logs=10)  # rcl_interfaces/msg/Log: DEBUG, INFO, ... FATAL

    result = imported(tmp_path, topics=["/rosout"])

    [first, *_] = [sample for _, samples in cycles_of(result.log) for sample in samples]
    assert first.value == {
        "stamp": {"sec": 0, "nanosec": 0},
        "level": 20,
        "name": "sonar_node",
        "msg": "echo 0",
        "file": "sonar.cpp",
        "function": "read",
        "line": 42,
    }


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
    assert summarize(result.log).header.start_time_ns == first_tick  # the first heartbeat's


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

    source = re.escape(inspect.getsourcefile(broken_perception) or "")
    assert re.fullmatch(
        rf"{re.escape(str(tmp_path / 'bag'))}: cycle 13: the perception step raised "
        rf"ValueError: sonar blinded \(line \d+ of {source}\)",
        str(raised.value),
    ), raised.value
    assert raised.value.user_traceback is not None
    assert (inspect.getsourcefile(broken_perception), "broken") in frames(
        raised.value.user_traceback
    )


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


def refused(tmp_path: Path, bag: Path, **options: object) -> str:
    """Why importing ``bag`` failed; it must fail, leaving neither a log nor a spec."""
    log, spec = tmp_path / "out.beatlog", tmp_path / "out.dtc.toml"
    settings: dict[str, object] = {"system": PROBE, "perception": PERCEPTION, **options}
    with pytest.raises(BagError) as raised:
        import_bag(bag, log, spec=spec, **settings)  # type: ignore[arg-type]
    assert [path.name for path in tmp_path.iterdir() if "out." in path.name] == []
    return str(raised.value)


def nth(topic_id: int, index: int) -> str:
    """The id of message ``index`` on a topic of a sqlite3 bag (1: /sonar, 2: /speed)."""
    return (
        f"SELECT id FROM messages WHERE topic_id = {topic_id} "
        f"ORDER BY timestamp LIMIT 1 OFFSET {index}"
    )


def delete_messages(database: Path, where: str) -> None:
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute(f"DELETE FROM messages WHERE {where}")


def drop_definitions(database: Path) -> None:
    """Drop the message definitions of a sqlite3 bag, as bags before ROS 2 Iron lack them."""
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute("DELETE FROM message_definitions")


def test_a_bag_that_lost_messages_its_metadata_counts_is_refused_naming_the_counts(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    delete_messages(storage_file(bag), f"id IN (({nth(1, 0)}), ({nth(1, 9)}), ({nth(2, 3)}))")

    assert refused(tmp_path, bag) == (
        f"{bag}: read 357 of the 360 messages its metadata counts "
        f"(topic /sonar: 298 of 300, topic /speed: 59 of 60); {MISMATCH}"
    )


def test_only_the_topics_imported_must_have_every_message(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    delete_messages(storage_file(bag), "topic_id = 2")  # every speed

    assert imported(tmp_path, topics=["/sonar"]).samples == 300
    assert refused(tmp_path, bag) == (
        f"{bag}: read 300 of the 360 messages its metadata counts (topic /speed: 0 of 60); the "
        "bag is damaged, or its metadata.yaml does not match its storage files"
    )


@pytest.mark.parametrize("storage", list(StoragePlugin))
def test_a_folder_whose_metadata_names_qos_its_storage_lacks_is_refused_not_empty(
    tmp_path: Path, storage: StoragePlugin
) -> None:
    bag = write_bag(tmp_path / "talker", storage=storage)
    name_other_qos(bag)  # as rosbag2's own talker test bags: rosbags matches no message

    assert refused(tmp_path, bag) == (
        f"{bag}: read 0 of the 360 messages its metadata counts "
        f"(topic /sonar: 0 of 300, topic /speed: 0 of 60); {MISMATCH}"
    )
    alone = import_bag(
        storage_file(bag), tmp_path / "file.beatlog", system=PROBE, perception=PERCEPTION
    )
    assert alone.samples == 360  # the storage file alone holds every message


@pytest.mark.parametrize("storage", list(StoragePlugin))
def test_a_folder_whose_storage_file_is_another_bags_is_refused(
    tmp_path: Path, storage: StoragePlugin
) -> None:
    bag = write_bag(tmp_path / "bag", storage=storage)
    other = write_bag(tmp_path / "other", storage=storage, sonars=100)
    storage_file(other).replace(storage_file(bag))  # the metadata.yaml of the first left

    assert refused(tmp_path, bag) == (
        f"{bag}: read 160 of the 360 messages its metadata counts (topic /sonar: 100 of 300); "
        f"{MISMATCH}"
    )


@pytest.mark.parametrize(
    ("edit", "problem"),
    [
        (
            lambda information: information.update(storage_identifier="sqlite3"),
            re.escape("not a readable ROS bag: AnyReaderError: Cannot open database ") + ".+",
        ),
        (
            lambda information: information.update(storage_identifier="bag_v2"),
            re.escape(
                "not a readable ROS bag: AnyReaderError: Storage plugin 'bag_v2' not supported"
            )
            + ".*",
        ),
        (
            lambda information: information.update(message_count=361),
            re.escape("its metadata counts 361 messages but 360 on its topics; the bag is damaged"),
        ),
    ],
    ids=["other storage", "unknown storage", "total"],
)
def test_a_folder_whose_metadata_does_not_fit_its_files_is_refused(
    tmp_path: Path, edit: Callable[[dict[str, Any]], object], problem: str
) -> None:
    bag = write_bag(tmp_path / "bag")
    edit_metadata(bag, edit)

    found = refused(tmp_path, bag)  # rosbags' words follow what it could not read
    assert re.fullmatch(re.escape(f"{bag}: ") + problem, found), found


def test_a_folder_naming_a_storage_file_it_lacks_names_that_file(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag")
    edit_metadata(bag, lambda information: information.update(relative_file_paths=["x.mcap"]))

    assert refused(tmp_path, bag) == f"{bag / 'x.mcap'}: no such file"
    (bag / "metadata.yaml").unlink()
    assert refused(tmp_path, bag) == f"{bag / 'metadata.yaml'}: no such file"


def test_a_storage_file_that_counts_more_messages_than_its_topics_hold_is_refused(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    database = storage_file(bag)
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute(f"UPDATE messages SET topic_id = 9 WHERE id = ({nth(1, 5)})")

    assert refused(tmp_path, database) == (
        f"{database}: its metadata counts 360 messages but 359 on its topics; the bag is damaged"
    )


def shift_message(database: Path, shift_ns: int) -> None:
    """Move the 6th sonar ``shift_ns`` later, as a flipped bit of its time would."""
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute(
            f"UPDATE messages SET timestamp = timestamp + ? WHERE id = ({nth(1, 5)})",
            [shift_ns],
        )


def test_a_message_far_outside_the_bags_span_is_refused_not_imported(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    shift_message(storage_file(bag), 10 * 10**9)  # more than the bag's 3 s span after it
    end = START_NS + 299 * SONAR_EVERY_NS + 1

    assert refused(tmp_path, bag) == (
        f"{bag}: a message on /sonar has log time {START_NS + 5 * SONAR_EVERY_NS + 10 * 10**9} "
        f"ns, far outside the bag's span as its metadata gives it ({START_NS} to {end} ns); "
        f"{MISMATCH}"
    )


def test_a_bag_spanning_more_heartbeats_than_an_import_writes_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(rosbag, "MAX_HEARTBEATS", 50)  # a storage file's time may be damaged
    bag = write_bag(tmp_path / "bag")  # too: then its span is all there is to go by

    assert refused(tmp_path, bag) == (
        f"{bag}: its messages span 3 s, 99 heartbeats of 30 ms, more than an import writes "
        "(50); choose a longer heartbeat period or a clock topic"
    )
    assert imported(tmp_path, clock_topic="/speed").cycles == 59


@pytest.fixture(scope="module")
def small_bags(tmp_path_factory: pytest.TempPathFactory) -> dict[StoragePlugin, Path]:
    """A small bag in each storage, 62 messages: 40 sonars, 8 speeds, 14 ticks."""
    root = tmp_path_factory.mktemp("small")
    return {
        storage: write_bag(root / storage.name, storage=storage, sonars=40, speeds=8, ticks=14)
        for storage in StoragePlugin
    }


FLIPS = 28


def flipped_bit(data: bytes, storage: StoragePlugin, flip: int) -> int:
    """Bit ``flip`` of the battery: the first 16 lie about the log time of the 18th sonar
    as the storage file holds it (its record's length, channel and times), the others are
    spread over the whole file."""
    if flip < 16:
        time = START_NS + 17 * SONAR_EVERY_NS
        at = data.index(time.to_bytes(8, "little" if storage is StoragePlugin.MCAP else "big"))
        return 8 * (at + flip - 8) + flip % 8
    return len(data) * 8 * (flip - 16) // (FLIPS - 16) + 5


@pytest.mark.parametrize(
    "flip",  # the targeted flips and every fourth spread one by default, the rest under -m slow
    [
        flip if flip < 16 or flip % 4 == 0 else pytest.param(flip, marks=pytest.mark.slow)
        for flip in range(FLIPS)
    ],
)
@pytest.mark.parametrize("storage", list(StoragePlugin), ids=lambda storage: storage.name)
def test_a_bag_with_a_flipped_bit_imports_every_message_or_is_refused(
    tmp_path: Path, small_bags: dict[StoragePlugin, Path], storage: StoragePlugin, flip: int
) -> None:
    bag = shutil.copytree(small_bags[storage], tmp_path / "bag")
    data = storage_file(bag)
    flip_bit(data, flipped_bit(data.read_bytes(), storage, flip))
    log = tmp_path / "out.beatlog"

    try:  # by the clock topic: a damaged time cannot make an import run for hours
        result = import_bag(bag, log, system=PROBE, perception=PERCEPTION, clock_topic="/tick")
    except BagError as error:
        problem = str(error)
    else:
        assert result.samples + result.left_out == 62
        return
    assert problem.startswith(f"{bag}: ")
    assert [path.name for path in tmp_path.iterdir()] == ["bag"]


def test_a_spec_that_cannot_be_written_leaves_no_log(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "bag")
    spec = tmp_path / "out.dtc.toml"
    spec.mkdir()  # replaced with overwrite, but a folder cannot be

    with pytest.raises(SpecError, match="cannot write"):
        import_bag(
            bag,
            tmp_path / "out.beatlog",
            system=PROBE,
            perception=PERCEPTION,
            spec=spec,
            overwrite=True,
        )
    assert not (tmp_path / "out.beatlog").exists()


def test_a_spec_in_a_missing_folder_is_refused_before_the_bag_is_read(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"cannot write: directory .* does not exist"):
        imported(tmp_path, spec=tmp_path / "nowhere" / "out.dtc.toml")
    assert not (tmp_path / "bag.beatlog").exists()


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
    drop_definitions(storage_file(bag))

    with pytest.raises(BagError, match="does not define message type my_robot_msgs/msg/Sonar"):
        imported(tmp_path)
    assert imported(tmp_path, topics=["/speed"]).samples == 60


@pytest.mark.parametrize("storage", list(StoragePlugin))
def test_a_topic_whose_message_definition_does_not_fit_its_messages_is_named(
    tmp_path: Path, storage: StoragePlugin
) -> None:
    bag = write_bag(tmp_path / "talker", storage=storage, logs=10, stub_log=True)

    assert refused(tmp_path, bag) == (
        f"{bag}: topic /rosout: its message definition of rcl_interfaces/msg/Log does not "
        "fit its messages (a stub definition?); import the others with --topic /sonar "
        "--topic /speed"
    )
    assert imported(tmp_path, topics=["/sonar", "/speed"]).samples == 360


def lengthen_speeds(database: Path, where: str = "TRUE") -> None:
    """Append 16 bytes to the speed messages ``where`` holds: more than a Float64 is."""
    with contextlib.closing(sqlite3.connect(database)) as connection, connection:
        connection.execute(
            f"UPDATE messages SET data = CAST(data || zeroblob(16) AS BLOB) "
            f"WHERE topic_id = 2 AND {where}"
        )


def test_messages_that_do_not_fit_the_standard_definition_of_their_type_are_named(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    drop_definitions(storage_file(bag))
    lengthen_speeds(storage_file(bag))

    assert refused(tmp_path, bag, topics=["/speed"]) == (
        f"{bag}: topic /speed: the standard definition of {SPEED} does not fit its messages "
        "(the bag defines no types: a type of another ROS release?)"
    )


def test_a_message_that_does_not_fit_where_the_ones_before_it_did_is_damage(
    tmp_path: Path,
) -> None:
    bag = write_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    lengthen_speeds(storage_file(bag), f"id = ({nth(2, 5)})")

    assert refused(tmp_path, bag) == (
        f"{bag}: damaged: AnyReaderError: CDR message size mismatch for '{SPEED}'."
    )
