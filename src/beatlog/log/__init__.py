"""The session log format: an MCAP container with msgpack records, written and read here.

The format knows nothing of behaviors or engines; it stores the cycles it is given.
The names are imported on first use: replay reads logs without loading the writer.
"""

from typing import TYPE_CHECKING

from beatlog._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.log.format import FORMAT_VERSION, CycleRecord, SessionEnd, SessionHeader
    from beatlog.log.index import recorded_cycles
    from beatlog.log.reader import LogStatus, SessionLogReader
    from beatlog.log.writer import SessionLogWriter

__all__ = [
    "FORMAT_VERSION",
    "CycleRecord",
    "LogStatus",
    "SessionEnd",
    "SessionHeader",
    "SessionLogReader",
    "SessionLogWriter",
    "recorded_cycles",
]

__getattr__ = lazy_names(
    __name__,
    {
        "FORMAT_VERSION": "beatlog.log.format",
        "CycleRecord": "beatlog.log.format",
        "LogStatus": "beatlog.log.reader",
        "SessionEnd": "beatlog.log.format",
        "SessionHeader": "beatlog.log.format",
        "SessionLogReader": "beatlog.log.reader",
        "SessionLogWriter": "beatlog.log.writer",
        "recorded_cycles": "beatlog.log.index",
    },
)
