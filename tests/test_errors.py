"""The errors beatlog raises for bad input: one hierarchy under ``BeatlogError``, each
message naming the file or reference it is about."""

from __future__ import annotations

from pathlib import Path

import pytest

import beatlog.errors
from beatlog.errors import (
    BaselineError,
    BeatlogError,
    ConversionError,
    CorruptLogError,
    FieldError,
    LogError,
    NotABeatlogError,
    SchemaMismatchError,
    SpecError,
    SystemLoadError,
    UnsupportedVersionError,
)

LOG_ERRORS = [NotABeatlogError, UnsupportedVersionError, CorruptLogError, SchemaMismatchError]


def test_every_error_beatlog_exports_is_a_beatlog_error() -> None:
    exported = [getattr(beatlog.errors, name) for name in beatlog.errors.__all__]

    assert exported
    assert all(issubclass(error, BeatlogError) for error in exported)
    assert not issubclass(BeatlogError, (ValueError, OSError, RuntimeError))


@pytest.mark.parametrize("error", [LogError, *LOG_ERRORS])
def test_a_log_error_names_the_file_and_the_problem(error: type[LogError]) -> None:
    raised = error("logs/probe.beatlog", "a chunk is damaged")

    assert isinstance(raised, LogError)
    assert str(raised) == f"{Path('logs/probe.beatlog')}: a chunk is damaged"
    assert raised.path == Path("logs/probe.beatlog")
    assert raised.problem == "a chunk is damaged"


@pytest.mark.parametrize("error", [SpecError, BaselineError])
def test_a_spec_error_names_the_file_and_the_problem(error: type[SpecError]) -> None:
    raised = error(Path("specs/avoid-pole.dtc.toml"), "key 'log': no such file")

    assert isinstance(raised, SpecError)
    assert str(raised) == f"{Path('specs/avoid-pole.dtc.toml')}: key 'log': no such file"
    assert raised.path == Path("specs/avoid-pole.dtc.toml")
    assert raised.problem == "key 'log': no such file"


def test_a_baseline_error_is_caught_as_a_spec_error() -> None:
    with pytest.raises(SpecError):
        raise BaselineError("avoid-pole.dtc.expected", "approved for another recording")


def test_log_spec_and_field_errors_are_separate_branches() -> None:
    assert not issubclass(SpecError, LogError)
    assert not issubclass(LogError, SpecError)
    assert not issubclass(FieldError, LogError | SpecError)


def test_a_system_load_error_keeps_the_users_traceback() -> None:
    kept = SystemLoadError("'robot:system': the factory raised", user_traceback="Traceback ...")
    bare = SystemLoadError("'robot:system': cannot import robot")

    assert str(kept) == "'robot:system': the factory raised"
    assert kept.user_traceback == "Traceback ..."
    assert bare.user_traceback is None


def test_an_error_not_from_user_code_has_no_user_traceback() -> None:
    assert CorruptLogError("probe.beatlog", "bad CRC").user_traceback is None
    assert FieldError("probe.beatlog: no field 'speed'").user_traceback is None


def test_a_conversion_error_is_a_beatlog_error_naming_the_field() -> None:
    error = ConversionError("pose.x", "cm() raised ValueError: too close", user_traceback="...")

    assert isinstance(error, BeatlogError)
    assert str(error) == "field 'pose.x': cm() raised ValueError: too close"
    assert error.user_traceback == "..."
