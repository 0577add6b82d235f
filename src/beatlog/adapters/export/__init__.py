"""Export a session log for viewers and for analysis; only the log is read, no code runs
(unless a system is given to replay, for its first divergence). The output's suffix
names the format (``.mcap``, ``.parquet``, ``.csv``) unless one is asked for, and a
format the suffix contradicts is refused before anything is written.

**MCAP for Foxglove and Lichtblick.** A ``.beatlog`` is MCAP, but its msgpack payloads
are not an encoding those viewers decode. The export writes message encoding ``json``
and schema encoding ``jsonschema``, one schema per channel (behavior channels share
one), each message stamped with the recording's start (the header's ``start_time_ns``,
Unix ns) plus the robot time at the end of its cycle, and sequence-numbered with its
cycle; a ``beatlog`` metadata record holds the header, says so, and says how the log
ends (``complete`` or ``truncated at cycle N: ...``). Both viewers read a JSON schema
with one parser (``parseJsonSchema`` in their ``mcap-support`` package), which takes
only an object with ``properties`` whose every field has one ``type``: boolean, string
(base64 with ``contentEncoding``), number, integer, an object with its own
``properties`` or an array of one of those.
Every schema here keeps to that, so every field is a typed field in the viewers'
message paths and plots, and every message validates against its schema:

- ``/robot_state``: RS_t, every cycle, as the header's robot-state schema declares
  it, every ``$ref`` inlined: numbers, integers, booleans and strings (an enum of
  strings or integers is one too), nested structs as objects, lists of those as
  arrays. What the viewers cannot type (a map, tuple, union, a list of lists or of
  nullables, a type inside itself) is a string of its JSON text. A null is left out.
  A log whose header declares no object is typed from a read of its fields.
- ``/behaviors/<name>``: a behavior's state after cycle 0, then after each change,
  as a string: the state as it prints (``idle``), or its JSON text if it is no
  string (``3``, ``true``). Before its first change a behavior's state is the
  ``before`` of that change; a behavior that never changes in the log has no known
  state and shows ``null``.
- ``/state_changes``: one Foxglove ``foxglove.Log`` message per change (INFO,
  ``avoid: idle -> turning``, the behavior as ``name``), for the Log panel. The
  schema is Foxglove's except ``level``: an integer here, not a ``oneOf`` of the
  level constants, which Lichtblick's parser refuses in releases that predate its
  enum support.
- ``/outputs``: the outputs of every cycle, each output a field typed as a first read
  of the log finds it (number, integer, boolean or string); an output whose values
  are lists, maps or of mixed types is a string of JSON text.
- ``/random_numbers``: the draws of each cycle that drew any: actor and kind, value
  and params as JSON text (a numpy array draw is dtype, shape and base64 bytes).
- ``/heartbeat``: HB_t of every cycle.
- ``/samples/<sensor>``: in a log recorded with samples, each raw sample (its stamp
  and value), typed as a first read of the log finds the sensor's values: maps with
  string keys as objects, lists as arrays, what the viewers cannot type as JSON text.
- ``/tf``: where the robot state has number fields ``x``, ``y`` and ``heading``,
  ``yaw`` or ``theta`` (radians, counter-clockwise; ``z`` too if it has one), at its
  top level or in an object field ``pose``, the robot's pose each cycle as Foxglove's
  ``foxglove.FrameTransform`` from ``odom`` to ``base_link``, for the 3D panel (none
  in a cycle where one of them is NaN or ±inf).
- ``/divergence``: with a system, one message at its first divergence from the log
  (``behavior`` empty when it concerns none; expected and actual state changes as
  lists of behavior, before and after strings).

JSON holds no NaN or infinity, and a plot's number field cannot hold a string: a
float field that is NaN or ±inf is left out of that message (a gap in a plot) and
listed in the message's ``non_finite`` string array as ``path=value``
(``distance=NaN``, ``pose.x=Infinity``, ``outputs.speed=-Infinity``). An array of
numbers that holds one anywhere in the log is, in that export, an array of the
numbers' texts (``["0.5", "NaN"]``): no schema can be an array of numbers for the
viewers and allow a null or a string in it for a validator. Inside JSON text they
are the strings ``"NaN"``, ``"Infinity"`` and ``"-Infinity"``, and bytes are base64.

**Tables** (Parquet, which needs the ``export`` extra, or CSV): one row per cycle
with ``cycle``, ``time_ns``, ``heartbeat_ns`` (robot time), one column per
robot-state field (``a.b`` for a nested struct's field), ``behavior.<name>`` (its
state after the cycle, as on the behavior channels; null while unknown),
``out.<name>`` and ``draws`` (how many random numbers the cycle drew). The columns'
types come from the header's robot-state schema and the behavior catalogue, so every
log of a system has the same Parquet schema, whatever its values: a number is a
double, an integer an int64, a list of those a list, a behavior's state a string; a
map, union or list of structs is JSON text. Outputs are typed from a read of the log
(numbers as doubles; lists, maps and mixed types as JSON text), and a log whose
header declares no object has its fields typed so too. The Parquet metadata holds
the header and how the log ends, as the MCAP's does (keys ``beatlog.<name>``).
Floats stay floats: Parquet keeps NaN and ±inf, CSV writes ``nan``, ``inf`` and
``-inf``; in CSV a list or map is its JSON text.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from beatlog.adapters.export.reading import Session, decoded_cycles, first_read, replacing_output
from beatlog.adapters.export.tables import pyarrow_modules, write_table
from beatlog.adapters.export.viewer import write_mcap
from beatlog.errors import ExportError
from beatlog.log.reader import LogStatus, SessionLogReader
from beatlog.model.behavior import System
from beatlog.replaying.judge import replay
from beatlog.replaying.verdict import Divergence

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
    with SessionLogReader(log) as reader, replacing_output(output) as part:
        session = Session(log, reader.header, decoded_cycles(reader), first)
        if chosen is ExportFormat.MCAP:
            write_mcap(part, session, replayed)
        else:
            write_table(part, session, as_csv=chosen is ExportFormat.CSV)
        status = reader.status
    return ExportResult(
        log=log,
        output=output,
        format=chosen,
        cycles=status.cycles,
        status=status,
        replayed=replayed is not None,
        divergence=None if replayed is None else replayed.divergence,
    )
