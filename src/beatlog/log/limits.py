"""Bounds on everything read from a log file, checked before the thing is trusted.

A session log may be damaged or hand-crafted; these bounds keep the work of reading
any file small and proportional to the file. Logs written by beatlog stay far below
each of them (the writer closes a chunk at about 1 MiB).
"""

from __future__ import annotations

__all__ = [
    "MAX_BEHAVIORS",
    "MAX_CHUNK_BYTES",
    "MAX_EXPANSION",
    "MAX_FIELDS",
    "MAX_NAME_LENGTH",
    "MAX_RECORD_BYTES",
    "MAX_SCHEMA_BYTES",
    "MAX_SETUP_DRAWS",
    "MAX_TEXT_LENGTH",
    "MAX_VALUE_WIDTH",
]

MAX_RECORD_BYTES = 1 << 30
"""The largest top-level MCAP record read from a file (and never more than the file holds)."""
MAX_CHUNK_BYTES = 16 << 20
"""The largest uncompressed chunk: the writer closes chunks at 1 MiB and batches at 1 MiB."""
MAX_EXPANSION = 1 << 10
"""The most bytes of uncompressed chunks per byte of the file, beyond one chunk's worth
(a decompression bomb). Recorded sessions expand 5-15 times; zstd reaches 1000 times
only on long runs of identical cycles."""
MAX_NAME_LENGTH = 256
"""Longest robot id, version string or behavior name."""
MAX_TEXT_LENGTH = 4096
"""Longest system reference, robot-state type name or error message."""
MAX_BEHAVIORS = 4096
"""Most behaviors in a catalogue."""
MAX_SCHEMA_BYTES = 1 << 20
"""Largest header message (the robot-state JSON schema is most of it)."""
MAX_SETUP_DRAWS = 1 << 16
"""Most random numbers a system draws while it is built (the header holds them)."""
MAX_FIELDS = 1 << 16
"""Most robot-state fields (columns) in a format-3 batch."""
MAX_VALUE_WIDTH = 64
"""Widest value of a byte-split column (a float's encoding is 9 bytes)."""
