"""One context-manager shape for everything beatlog opens and must close."""

from __future__ import annotations

from typing import Self

__all__ = ["Closing"]


class Closing:
    """A context manager for an object with :meth:`close`: the ``with`` block ends by
    closing it, whether the block raised or not."""

    def close(self) -> None:
        """Release what the object holds (a file, a thread, a process)."""
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
