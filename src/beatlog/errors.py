"""The exceptions beatlog raises for bad input; programming errors stay ordinary exceptions."""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "BagError",
    "BaselineError",
    "BeatlogError",
    "CiWriteError",
    "ClusterError",
    "ConversionError",
    "CorruptLogError",
    "EmptyCheckError",
    "EmptySelectionError",
    "ExportError",
    "FieldError",
    "FileProblemError",
    "FleetError",
    "LogError",
    "LogExistsError",
    "NotABeatlogError",
    "NumpyMissingError",
    "OptionError",
    "RemoteLogError",
    "SchemaMismatchError",
    "SpecError",
    "SystemLoadError",
    "UnsupportedVersionError",
    "WindowError",
]


class BeatlogError(Exception):
    """Root of every error caused by input a user gave (a file, an option, a factory name)."""

    user_traceback: str | None = None
    """The traceback of the user's code behind the error, when their code raised it."""


class FileProblemError(BeatlogError):
    """A file given that cannot be used: the message names the file and the problem."""

    def __init__(
        self, path: str | Path, problem: str, *, user_traceback: str | None = None
    ) -> None:
        self.path = Path(path)
        self.problem = problem
        self.user_traceback = user_traceback
        super().__init__(f"{self.path}: {problem}")


class LogError(FileProblemError):
    """A session log that cannot be read; the message names the file and the problem."""


class LogExistsError(LogError):
    """A recording would replace an existing session log; recordings are immutable."""

    def __init__(self, path: str | Path) -> None:
        super().__init__(
            path, "already exists; recordings are immutable (overwrite=True replaces it)"
        )


class NotABeatlogError(LogError):
    """The file is missing, empty, not MCAP, or MCAP written by another tool."""


class UnsupportedVersionError(LogError):
    """The log was written with a newer format version than this beatlog reads."""


class CorruptLogError(LogError):
    """A record inside the log is damaged (bad CRC, bad payload) before its end."""


class SchemaMismatchError(LogError):
    """The log does not fit the system: its robot state is not the system's robot state
    type (or a cycle's does not decode into it), or none of its behaviors is the system's."""


class EmptyCheckError(LogError):
    """A replay that found no difference but checked nothing: the log holds no cycle, or
    none in which a behavior changed state, reported an output, drew a random number or
    was given a sample. A pass over nothing is no pass, unless allowed
    (``allow_empty``)."""


class BagError(FileProblemError):
    """A ROS bag that cannot be imported as a session log: missing, damaged, without the
    messages asked for, or refused by the user's perception step or system; the message
    names the bag and the problem."""


class NumpyMissingError(BeatlogError, ModuleNotFoundError):
    """Array draws made or replayed where numpy is not installed (only they need it); the
    message names the log, where one is known, and the extra that brings numpy. It is a
    :class:`ModuleNotFoundError` too, so ``except ImportError`` catches it."""

    def __init__(self, log: str | Path | None = None) -> None:
        self.log = log
        """The session log being recorded or replayed, or None."""
        where = "" if log is None else f"{log}: "
        super().__init__(
            f"{where}array draws (uniform_array, normal_array, integers_array) need numpy: "
            'pip install "beatlog[arrays]"',
            name="numpy",
        )


class ExportError(BeatlogError):
    """A session log that cannot be exported as asked: the output cannot be written, an
    optional package is missing, or the option does not fit the format."""


class FieldError(BeatlogError):
    """A robot-state field named for a chart or a tolerance that the session's robot
    state lacks, or one charted that is not a number; the message names the log."""


class FleetError(BeatlogError):
    """The logs of a fleet run cannot be found or fetched; the message names the pattern
    or the log."""


class RemoteLogError(BeatlogError):
    """A log behind a URL that cannot be fetched: fsspec is not installed, or the log is
    missing, unreachable or too large; the message names the URL and the problem."""

    def __init__(self, url: str, problem: str) -> None:
        self.url = url
        self.problem = problem
        super().__init__(f"{url}: {problem}")


class ClusterError(BeatlogError):
    """A Dask cluster that a suite cannot run on: no scheduler answers at its address, or
    dask.distributed is not installed; the message names the address."""


class OptionError(BeatlogError):
    """An option given a value it does not take; the message lists the values it does."""


class EmptySelectionError(OptionError):
    """DTC specs are found, and the selection (``-k``, ``--tag``) leaves none to run:
    ``beatlog test`` exits 5 for it, as pytest does when no test is selected."""


class CiWriteError(BeatlogError):
    """A baseline write asked for while ``CI`` is set: beatlog never writes baselines in CI."""

    def __init__(self) -> None:
        super().__init__("CI is set: beatlog never writes baselines in CI")


class SystemLoadError(BeatlogError):
    """A ``module:factory`` reference that cannot be imported or does not build a system."""

    def __init__(self, message: str, *, user_traceback: str | None = None) -> None:
        super().__init__(message)
        self.user_traceback = user_traceback


class ConversionError(BeatlogError):
    """A recorded robot-state value that did not become the system's under a field
    conversion or rename: names the field and why; ``user_traceback`` is that of the
    user's conversion, if it raised."""

    def __init__(self, field: str, problem: str, *, user_traceback: str | None = None) -> None:
        super().__init__(f"field {field!r}: {problem}")
        self.field = field
        self.user_traceback = user_traceback


class SpecError(FileProblemError):
    """A DTC spec (``*.dtc.toml``) that cannot be read; the message names the file and key."""


class WindowError(FileProblemError):
    """A window of cycles (``start_cycle``, ``end_cycle``) that the log does not hold:
    names the spec that set it (or the log), the key and the cycle past the log's end."""


class BaselineError(SpecError):
    """An approved or pending baseline of a spec that cannot be read or no longer fits."""


def first_line(exc: BaseException) -> str:
    """An exception as one line, for a message about someone else's error (a backend's,
    a cluster's): its message's first line, or its type's name."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
