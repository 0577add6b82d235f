"""What a suite session is asked to do: which DTCs to run, how, and which reports to
write. The options of ``beatlog test``, as one typed object that checks how they go
together when it is made."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from beatlog.baseline.policy import UpdateMode
from beatlog.errors import OptionError

if TYPE_CHECKING:
    from beatlog.suite.sharding import Shard

__all__ = ["SuiteOptions"]

_HERE = (Path(),)


@dataclass(frozen=True, kw_only=True)
class SuiteOptions:
    """A suite session's options (see :class:`beatlog.report.session.SuiteSession`).

    :raises OptionError: options that do not go together, named as ``beatlog test``
        names them: ``system`` or ``perception`` without ``logs`` (a spec names its
        own), ``logs`` without ``system``, or with ``paths``, an update or
        ``last_failed``.
    """

    paths: tuple[Path, ...] = _HERE
    """Specs (``*.dtc.toml``) or folders searched for them."""
    pattern: str | None = None
    """Only the DTCs matching this ``-k`` expression."""
    tags: tuple[str, ...] = ()
    """Only the DTCs with every one of these tags."""
    behavior: str | None = None
    """Only the DTCs whose recordings change this behavior's state."""
    shard: Shard | None = None
    """Only this shard's share of the DTCs selected."""
    logs: str | None = None
    """Replay every log matching this glob (or URL) against ``system``: no spec needed."""
    system: str | None = None
    """The system factory (``module:factory``) of a ``logs`` run."""
    perception: str | None = None
    """The perception step of a ``logs`` run."""
    jobs: int | None = None
    """Processes replaying at once; by default, the number of cores."""
    dask: str | None = None
    """The Dask cluster to run on (:class:`~beatlog.suite.cluster.DaskExecutor`)."""
    fail_fast: bool = False
    """Stop after the first DTC that fails or cannot run; those not started are not run."""
    last_failed: bool = False
    """Run only the DTCs selected that failed last time, or all when none did
    (:mod:`beatlog.suite.last_failed`)."""
    update: UpdateMode = UpdateMode.NONE
    audit: bool = False
    coverage: bool = False
    """Show the transition coverage (remembered in the coverage memory)."""
    coverage_json: Path | None = None
    junit_xml: Path | None = None
    html: Path | None = None
    break_at: int | None = None
    """Stop in the debugger just before the behaviors update in this cycle of the one
    DTC selected."""
    break_on_divergence: bool = False
    """Replay each failing DTC again and stop in the debugger at its first divergence."""
    variants: int | None = None
    """Variants 1..N of each DTC that declares variants (``[variants]``); None: as many
    as each declares (its ``count``)."""

    def __post_init__(self) -> None:
        if self.logs is None:
            if self.system is not None or self.perception is not None:
                raise OptionError("--system and --perception go with --logs: a spec names its own")
            return
        if self.system is None:
            raise OptionError("--logs needs --system MODULE:FACTORY to replay the logs against")
        if self.paths != _HERE:
            raise OptionError("give DTC specs or --logs, not both")
        if self.update is not UpdateMode.NONE:
            raise OptionError("--update writes the baselines of specs; --logs runs have none")
        if self.last_failed:
            raise OptionError("--lf reruns the specs that failed; --logs runs are not remembered")

    @property
    def reports(self) -> tuple[Path, ...]:
        """The report files to write."""
        reports = (self.junit_xml, self.html, self.coverage_json)
        return tuple(report for report in reports if report is not None)

    @property
    def breaking(self) -> bool:
        """Whether the run stops in the debugger."""
        return self.break_at is not None or self.break_on_divergence
