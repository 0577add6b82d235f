"""The session log format: an MCAP container with msgpack records, written and read here.

The format knows nothing of behaviors or engines; it stores the cycles it is given.
The names are imported on first use: replay reads logs without loading the writer.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.log.format import FORMAT_VERSION as FORMAT_VERSION
    from beatlog.log.format import CycleRecord as CycleRecord
    from beatlog.log.format import SessionEnd as SessionEnd
    from beatlog.log.format import SessionHeader as SessionHeader
    from beatlog.log.index import recorded_cycles as recorded_cycles
    from beatlog.log.reader import LogStatus as LogStatus
    from beatlog.log.reader import SessionLogReader as SessionLogReader
    from beatlog.log.writer import SessionLogWriter as SessionLogWriter

__getattr__ = lazy_names(__name__)
