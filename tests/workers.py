"""Dask worker plugins for the cluster tests: workers, importing this module, run them."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from distributed import Worker, WorkerPlugin


class DyingWhenFetched(WorkerPlugin):
    """The first time a client asks a worker for what a DTC task returned (``marker``
    then exists), the worker's process ends, as a crash would, with the outcomes it holds
    not yet fetched."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def setup(self, worker: Worker) -> None:
        serve = worker.handlers["get_data"]

        async def get_data(comm: object, keys: Sequence[object] = (), **kwargs: Any) -> Any:
            if any(str(key).startswith("dtc-") for key in keys) and not self.marker.exists():
                self.marker.touch()
                os._exit(3)
            return await serve(comm, keys=keys, **kwargs)

        worker.handlers["get_data"] = get_data
