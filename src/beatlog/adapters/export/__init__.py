"""Export a session log for viewers and for analysis; only the log is read, no code runs
(unless a system is given to replay, for its first divergence).

MCAP with JSON messages and JSON schemas (:mod:`.viewer`) is what Foxglove and
Lichtblick decode, which a ``.beatlog``'s msgpack payloads are not: every schema keeps
to the one shape their parser reads, so every field is typed for their panels and
plots. A table (:mod:`.tables`, Parquet or CSV) has one row per cycle, its columns
typed by the header and the behavior catalogue, so every log of a system has the same
schema. The channels, columns and how NaN, bytes and untyped values are written:
the how-to guide "Export to Foxglove, Lichtblick, Parquet".
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from beatlog.adapters.export.reading import Session, decoded_cycles, first_read
from beatlog.adapters.export.tables import pyarrow_modules, write_table
from beatlog.adapters.export.viewer import write_mcap
from beatlog.errors import ExportError
from beatlog.log.files import replacing
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import System
from beatlog.replay.judge import replay
from beatlog.replay.verdict import Divergence

__all__ = ["ExportFormat", "ExportResult", "export", "export_format"]


class ExportFormat(StrEnum):
    """What ``beatlog export`` writes."""

    MCAP = "mcap"
    """MCAP with JSON messages and JSON schemas, for Foxglove and Lichtblick."""
    PARQUET = "parquet"
    """One row per cycle in Parquet (needs pyarrow: ``pip install "beatlog[export]"``)."""
    CSV = "csv"
    """One row per cycle as comma-separated text."""

    @property
    def suffix(self) -> str:
        """The suffix of a file in this format: ``.mcap``, ``.parquet`` or ``.csv``."""
        return f".{self.value}"


def export_format(output: str | Path, format: ExportFormat | str | None = None) -> ExportFormat:
    """The format ``output`` is written in: ``format``, or the one its suffix names
    (``.mcap``, ``.parquet`` or ``.csv``) when ``format`` is None.

    :raises beatlog.errors.ExportError: ``format`` names no format, the suffix names
        another one, or no format is given and the suffix names none.
    """
    suffix = Path(output).suffix.lower()
    named = next((chosen for chosen in ExportFormat if chosen.suffix == suffix), None)
    if format is None:
        if named is None:
            given = f"suffix {suffix}" if suffix else "no suffix"
            known = ", ".join(chosen.suffix for chosen in ExportFormat)
            raise ExportError(
                f"{output}: an export is written as {known}, not {given}; or name the format"
            )
        return named
    try:
        chosen = ExportFormat(format)
    except ValueError:
        choices = ", ".join(ExportFormat)
        raise ExportError(f"cannot export as {format!r}; choose one of {choices}") from None
    if named is not None and named is not chosen:
        raise ExportError(
            f"{output}: a {suffix} file is not written as {chosen}; "
            f"name it {chosen.suffix} or export as {named}"
        )
    return chosen


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote."""

    log: Path
    output: Path
    format: ExportFormat
    cycles: int
    status: LogStatus
    """How the log ended; a truncated log is exported up to its last complete cycle."""
    replayed: bool
    """Whether a system was replayed for the divergence."""
    divergence: Divergence | None
    """The replay's first divergence, when a system was replayed and it diverged."""
    url: str | None = None
    """The URL of the log, when it lay behind one: ``log`` is then the copy exported,
    which is gone."""

    @property
    def log_name(self) -> str:
        """The log as messages name it: its URL, or its path."""
        return str(self.log) if self.url is None else self.url

    def describe(self) -> str:
        """One line for people: what was written, how the log ended, what replay found."""
        line = f"exported {self.cycles} cycles of {self.log_name} to {self.output} ({self.format})"
        if not self.status.complete:
            line += f"; the log is {self.status.describe()}"
        if self.divergence is not None:
            line += f"; first divergence at cycle {self.divergence.cycle} ({self.divergence.kind})"
        elif self.replayed:
            line += "; the replay passed"
        return line


def export(
    log: str | Path,
    output: str | Path,
    *,
    format: ExportFormat | str | None = None,
    system: System | str | None = None,
) -> ExportResult:
    """Write ``log`` to ``output`` in ``format`` (by default the one the output's suffix
    names, see :func:`export_format`); with ``system`` (MCAP only), replay the log
    against it and add its first divergence.

    The output is written next to its final place and moved there when complete, so
    an export that fails (a damaged log, a full disk) leaves no partial file.

    :raises beatlog.errors.LogError: the log cannot be read (or does not fit ``system``).
    :raises beatlog.errors.ExportError: the format does not fit the output's suffix, the
        output cannot be written, Parquet is asked for without pyarrow, or a system is
        given for a table.
    """
    log, output = Path(log), Path(output)
    chosen = export_format(output, format)
    if system is not None and chosen is not ExportFormat.MCAP:
        raise ExportError(f"a replay's divergence is exported to MCAP only, not {chosen}")
    if chosen is ExportFormat.PARQUET:
        pyarrow_modules()
    if output.exists() and log.exists() and output.samefile(log):
        raise ExportError(f"{output}: is the session log being exported; name another file")
    replayed = (
        None
        if system is None
        else replay(log, system, allow_truncated=True, allow_empty=True, explain=False)
    )
    first = first_read(log)
    try:
        with SessionLogReader(log) as reader, replacing(output) as file:
            session = Session(log, reader.header, decoded_cycles(reader), first)
            if chosen is ExportFormat.MCAP:
                write_mcap(file, session, replayed)
            else:
                write_table(file, session, as_csv=chosen is ExportFormat.CSV)
            status = reader.status
    except OSError as exc:
        raise ExportError(f"{output}: cannot write: {exc.strerror or exc}") from None
    return ExportResult(
        log=log,
        output=output,
        format=chosen,
        cycles=status.cycles,
        status=status,
        replayed=replayed is not None,
        divergence=None if replayed is None else replayed.divergence,
    )
