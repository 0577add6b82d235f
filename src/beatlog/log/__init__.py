"""The session log format: an MCAP container with msgpack records, written and read here.

The format knows nothing of behaviors or engines; it stores the cycles it is given.
"""

from beatlog.log.format import FORMAT_VERSION, CycleRecord, SessionEnd, SessionHeader
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
]
