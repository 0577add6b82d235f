"""A fleet in object storage on a local cluster: N small logs on an S3-compatible server
on the loopback (moto's, reached through s3fs), each request delayed, replayed by
``--dask local:W`` as ``beatlog test --logs s3://... --dask local:W`` replays them.

Measured, in this process (the suite's client) with the server in a thread of its own:
the requests the server answered before the first task was submitted (listing and
ordering the fleet), the cluster's start-up, the time from submission to the first
outcome and to the last, the sum of the replays' wall times (each DTC's own, as its
worker timed it) against the fleet's wall time per worker, the time the DTCs spent
waiting for storage, the server's requests by method a log, and the bytes of logs the
server sent; then the same run again on a fresh cluster, which must fetch no log again
(the machine's cache of logs) nor ask the server anything of one, ``--reruns`` times,
each against the replays' CPU in one process measured just before and just after it, and
against the wall time of the same replays in W processes at once without a cluster (what
the cores give when all of them replay at once).

Needs ``pip install s3fs "moto[server]"``. Run it as ``python bench/bench_fleet_s3.py
[--logs N] [--workers W] [--latency-ms L] [--seconds S] [--reruns R]``.
"""

from __future__ import annotations

import argparse
import collections
import io
import logging
import multiprocessing
import os
import resource
import statistics
import tempfile
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from beatlog.baseline.policy import SpecOptions
from beatlog.suite.cluster import DaskExecutor
from beatlog.suite.parallel import longest_first
from beatlog.suite.runner import SpecOutcome, Verdict, run_spec
from beatlog.suite.selection import fleet_specs
from beatlog.suite.spec import DtcSpec
from beatlog_examples.rover import record_lockstep

BUCKET = "fleet"
ROVER = "beatlog_examples.rover:system"


class Delayed:
    """A WSGI application that answers each request after ``latency`` seconds, counting
    the requests and the bytes of ``GET`` bodies sent."""

    def __init__(self, app: Callable[..., Iterable[bytes]], latency: float) -> None:
        self.app, self.latency = app, latency
        self.requests: collections.Counter[str] = collections.Counter()
        self.sent = 0
        self.lock = threading.Lock()

    def __call__(self, environ: dict[str, Any], start: Callable[..., Any]) -> Iterable[bytes]:
        listing = "list-type" in environ["QUERY_STRING"]
        with self.lock:
            self.requests["LIST" if listing else environ["REQUEST_METHOD"]] += 1
        time.sleep(self.latency)
        body = b"".join(self.app(environ, start))
        if environ["REQUEST_METHOD"] == "GET" and "list-type" not in environ["QUERY_STRING"]:
            with self.lock:
                self.sent += len(body)
        return [body]

    def by_method(self) -> collections.Counter[str]:
        """Requests so far by method, a listing as ``LIST``."""
        with self.lock:
            return collections.Counter(self.requests)

    def counted(self) -> tuple[int, int]:
        """Requests and bytes sent so far."""
        with self.lock:
            return sum(self.requests.values()), self.sent


def serve(latency: float) -> tuple[str, Delayed]:
    """An S3-compatible server on the loopback, in a thread: its URL and its counter."""
    from moto.moto_server.werkzeug_app import (  # noqa: PLC0415
        DomainDispatcherApplication,
        MotoRequestHandler,
        create_backend_app,
    )
    from werkzeug.serving import make_server  # noqa: PLC0415

    logging.getLogger("werkzeug").setLevel(logging.WARNING)  # no line per request
    delayed = Delayed(DomainDispatcherApplication(create_backend_app), latency)
    server = make_server("127.0.0.1", 0, delayed, threaded=True, request_handler=MotoRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    host, port = server.server_address[:2]
    return f"http://{host!s}:{port}", delayed


def upload(endpoint: str, log: Path, count: int) -> None:
    """``count`` copies of ``log`` in the bucket, under ``fleet/``."""
    import s3fs  # noqa: PLC0415

    storage = s3fs.S3FileSystem(endpoint_url=endpoint, key="k", secret="s")
    storage.mkdir(BUCKET)
    data = log.read_bytes()
    for index in range(count):
        storage.pipe(f"{BUCKET}/fleet/log-{index:04}.beatlog", data)


def run_fleet(workers: int, delayed: Delayed) -> dict[str, float]:
    """One fleet run on a fresh local cluster; its figures."""
    requests, sent = delayed.counted()
    methods = delayed.by_method()
    own, children = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    with DaskExecutor(f"local:{workers}") as executor:
        ready = time.perf_counter()
        specs = fleet_specs(f"s3://{BUCKET}/fleet/*.beatlog", system=ROVER)
        longest_first(specs)
        planned = delayed.counted()[0] - requests
        outcomes: list[tuple[float, SpecOutcome]] = []
        submitted = time.perf_counter()

        def done(outcome: SpecOutcome) -> bool:
            outcomes.append((time.perf_counter(), outcome))
            return False

        executor(specs, SpecOptions(), done)
        finished = time.perf_counter()
    own, children = _cpu(resource.RUSAGE_SELF) - own, _cpu(resource.RUSAGE_CHILDREN) - children
    assert all(outcome.verdict is Verdict.PASSED for _, outcome in outcomes), [
        outcome.error for _, outcome in outcomes if outcome.verdict is not Verdict.PASSED
    ][:3]
    waits = [outcome.storage_wait_s or 0.0 for _, outcome in outcomes]
    replays = sum(outcome.wall_time_s for _, outcome in outcomes)
    return {
        "logs": len(outcomes),
        "start-up s": ready - started,
        "requests to plan": planned,
        "first outcome s after submission": min(at for at, _ in outcomes) - submitted,
        "fleet wall s after submission": finished - submitted,
        "replays' wall sum / workers s": replays / workers,
        "median wait for storage ms": statistics.median(waits) * 1000,
        "total wait for storage s": sum(waits),
        "requests": delayed.counted()[0] - requests,
        **{
            f"{method} a log": count / len(outcomes)
            for method, count in (delayed.by_method() - methods).items()
            if method != "LIST"
        },
        "log bytes sent": delayed.counted()[1] - sent,
        "client, scheduler and server CPU a DTC ms": own / len(outcomes) * 1000,
        "workers' CPU a DTC ms (start-up included)": children / len(outcomes) * 1000,
    }


def idle_cluster(workers: int) -> dict[str, float]:
    """The CPU of starting and closing a cluster that replays nothing, to take from a
    fleet run's for the CPU a DTC costs."""
    own, children = _cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN)
    with DaskExecutor(f"local:{workers}"):
        pass
    return {
        "client": _cpu(resource.RUSAGE_SELF) - own,
        "workers": _cpu(resource.RUSAGE_CHILDREN) - children,
    }


def _cpu(who: int) -> float:
    """CPU seconds used so far by this process (``RUSAGE_SELF``) or its ended children."""
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def _replayed(specs: list[DtcSpec]) -> None:
    """Replay ``specs`` one after another in this process; each must pass."""
    for spec in specs:
        assert run_spec(spec, SpecOptions()).verdict is Verdict.PASSED


def replay_cpu(specs: list[DtcSpec]) -> float:
    """The CPU seconds of replaying ``specs`` one after another in this process, from
    the machine's cache of logs: the fleet's replay CPU, without a cluster."""
    started = time.process_time()
    _replayed(specs)
    return time.process_time() - started


def parallel_wall(specs: list[DtcSpec], workers: int) -> float:
    """The wall seconds of replaying ``specs`` in ``workers`` processes at once, from the
    machine's cache of logs, without a cluster: what the cores give when all replay at
    once, after each process has replayed one DTC to warm up."""
    chunks = [specs[start::workers] for start in range(workers)]
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(_replayed, [chunk[:1] for chunk in chunks]))
        started = time.perf_counter()
        list(pool.map(_replayed, chunks))
        return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=int, default=1000, help="logs in the fleet")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--latency-ms", type=float, default=50.0, help="delay per request")
    parser.add_argument("--seconds", type=float, default=3.0, help="robot time of each log")
    parser.add_argument("--reruns", type=int, default=2, help="runs from the cache, each timed")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        os.environ.update(
            AWS_ACCESS_KEY_ID="k",
            AWS_SECRET_ACCESS_KEY="s",
            AWS_DEFAULT_REGION="us-east-1",
            BEATLOG_CACHE_DIR=str(Path(scratch, "cache")),
        )
        endpoint, delayed = serve(0.0)
        os.environ["FSSPEC_S3_ENDPOINT_URL"] = endpoint  # the workers' s3fs, and ours
        import fsspec.config  # noqa: PLC0415

        fsspec.config.set_conf_env(fsspec.config.conf)
        log = Path(scratch, "walk.beatlog")
        record_lockstep(log, duration_s=args.seconds, seed=1)
        upload(endpoint, log, args.logs)
        delayed.latency = args.latency_ms / 1000
        out = io.StringIO()
        print(
            f"{args.logs} logs of {log.stat().st_size} bytes ({args.seconds:g} s robot time), "
            f"{args.workers} workers, {args.latency_ms:g} ms per request",
            file=out,
        )
        idle = idle_cluster(args.workers)
        print(
            f"a cluster started and closed, replaying nothing: client and scheduler CPU "
            f"{idle['client']:.3g} s, workers' CPU {idle['workers']:.3g} s",
            file=out,
        )
        runs = {"first run": run_fleet(args.workers, delayed)}
        specs = fleet_specs(f"s3://{BUCKET}/fleet/*.beatlog", system=ROVER)
        cpus = [replay_cpu(specs)]  # before and after each rerun: the machine's speed drifts
        walls = [parallel_wall(specs, args.workers)]
        for rerun in range(1, args.reruns + 1):
            runs[f"rerun {rerun}"] = run_fleet(args.workers, delayed)
            cpus.append(replay_cpu(specs))
            walls.append(parallel_wall(specs, args.workers))
        for run, figures in runs.items():
            print(run + ": " + ", ".join(f"{k} {v:.3g}" for k, v in figures.items()), file=out)
        print(
            "replays in one process, from the cache, before and after each rerun: "
            + ", ".join(f"{cpu / len(specs) * 1000:.3g}" for cpu in cpus)
            + " ms CPU a DTC; in "
            + f"{args.workers} processes at once, without a cluster: "
            + ", ".join(f"{wall:.3g}" for wall in walls)
            + " s wall",
            file=out,
        )
        for rerun in range(1, args.reruns + 1):
            figures = runs[f"rerun {rerun}"]
            cpu = (cpus[rerun - 1] + cpus[rerun]) / 2
            fleet = figures["fleet wall s after submission"]
            whole = figures["start-up s"] + fleet
            target = 1.3 * cpu / args.workers + figures["start-up s"]
            ratio = fleet / (cpu / args.workers)
            parallel = (walls[rerun - 1] + walls[rerun]) / 2
            print(
                f"rerun {rerun}: fleet wall / (replay CPU / workers) {ratio:.3g}, "
                f"/ the replays in {args.workers} processes at once {fleet / parallel:.3g}; "
                f"start-up and fleet {whole:.3g} s against 1.3 x replay CPU / workers + start-up "
                f"{target:.3g} s ({'met' if whole <= target else 'not met'})",
                file=out,
            )
        print(out.getvalue(), end="")


if __name__ == "__main__":
    main()
