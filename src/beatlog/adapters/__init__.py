"""Adapters to the tools people already use: a session log exported as MCAP with JSON
payloads for Foxglove and Lichtblick, or as a table (Parquet, CSV) for analysis."""

from beatlog.adapters.export import ExportFormat, ExportResult, export

__all__ = ["ExportFormat", "ExportResult", "export"]
