"""The formats ``beatlog export`` writes, and the one an output's suffix names."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

from beatlog.errors import ExportError

__all__ = ["ExportFormat", "export_format"]


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
