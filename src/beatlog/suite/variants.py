"""Variants in a suite: each DTC that declares variants (a ``[variants]`` table in its
spec or its project's ``[tool.beatlog.variants]``) runs as itself and as variants 1..N,
each a DTC of its own (:attr:`~beatlog.suite.spec.DtcSpec.variant`); a variant that
fails is written as a spec beside the original, ``<stem>.variant-<n>.dtc.toml``, which
later runs and pytest find and run as a DTC of its own, failing the same way."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from pathlib import Path

from beatlog.errors import SpecError, SystemLoadError
from beatlog.log.files import project_root
from beatlog.project.config import project_config
from beatlog.project.usercode import load_invariant, load_perception, load_system
from beatlog.replay.perturbation import Perturbations, Variant
from beatlog.replay.variant import replay_variant
from beatlog.replay.verdict import ReplayResult, reproduce_command
from beatlog.suite.spec import DtcSpec, spec_toml

__all__ = ["importable_invariants", "replay_variant_of", "with_variants", "write_variant_spec"]


def replay_variant_of(spec: DtcSpec, system: str) -> ReplayResult:
    """Replay variant ``spec`` of a DTC against ``system`` (``module:factory``):
    perturbed, judged by its behaviors not raising and its invariants."""
    assert spec.variant is not None  # a variant's
    perception = None if spec.perception is None else load_perception(spec.perception)
    return replay_variant(
        spec.log,
        load_system(system),
        Variant(spec.variant, spec.perturbations or Perturbations()),
        perception=perception,
        migration=spec.migration,
        allow_truncated=spec.allow_truncated,
        invariants=importable_invariants(spec),
        where=spec.path,
        reproduce=reproduce_command("test", spec.own_spec),
        start_cycle=spec.start_cycle,
        end_cycle=spec.end_cycle,
        fresh_start=spec.fresh_start,
    )


def with_variants(specs: Iterable[DtcSpec], count: int | None = None) -> list[DtcSpec]:
    """``specs``, each DTC that declares variants followed by its variants 1..N: N is
    ``count`` where given (``--variants``), else the DTC's own count. A variant's spec is
    one already, and a fleet log has none."""
    run: list[DtcSpec] = []
    for spec in specs:
        run.append(spec)
        if spec.perturbations is None or spec.variant is not None or spec.source is not None:
            continue
        for number in range(1, (spec.variant_count if count is None else count) + 1):
            run.append(
                dataclasses.replace(
                    spec,
                    name=f"{spec.name}[variant-{number}]",
                    id=f"{spec.id}[variant-{number}]",
                    variant=number,
                )
            )
    return run


def write_variant_spec(spec: DtcSpec) -> Path:
    """Write variant ``spec`` of a DTC as a spec beside the original, its path: with all
    it replays with, so that it reproduces whatever the original or the project say later.

    :raises beatlog.errors.SpecError: it cannot be written.
    """
    assert spec.variant is not None  # a variant's
    assert spec.perturbations is not None
    base = spec.name.removesuffix(f"[variant-{spec.variant}]")
    data = {
        "name": f"{base}-variant-{spec.variant}",
        "purpose": f"Variant {spec.variant} of {base}, which failed: {spec.purpose}",
        "procedure": spec.procedure,
        "log": spec.log_url or Path(os.path.relpath(spec.log, spec.path.parent)).as_posix(),
        "system": spec.system,
        "perception": spec.perception,
        "tags": spec.tags,
        "invariants": spec.invariants,
        "allow_truncated": spec.allow_truncated,
        "start_cycle": spec.start_cycle,
        "end_cycle": spec.end_cycle,
        "fresh_start": spec.fresh_start,
        "variant": spec.variant,
        "field_renames": dict(spec.migration.renames),
        "field_conversions": dict(spec.migration.conversions),
        "variants": dataclasses.asdict(spec.perturbations),
    }
    path = spec.own_spec
    try:
        path.write_text(spec_toml(data), "utf-8")
    except OSError as exc:
        raise SpecError(path, f"cannot write: {exc.strerror}") from None
    return path


def importable_invariants(spec: DtcSpec) -> tuple[str, ...]:
    """The spec's invariants, each imported once here, so that one that does not import
    is an error naming where it is listed: the spec or its ``pyproject.toml``.

    :raises beatlog.errors.SystemLoadError: one does not import, or is no invariant.
    """
    if not spec.invariants:  # a fleet log's DTC, or a spec that names none
        return spec.invariants
    folder = spec.path.resolve().parent
    project = project_config(folder).invariants if spec.source is None else []
    for reference in spec.invariants:
        try:
            load_invariant(reference)
        except SystemLoadError as exc:
            root = project_root(folder)
            if root is None or reference not in project:
                raise
            listed = f"listed under [tool.beatlog] invariants in {root / 'pyproject.toml'}"
            raise SystemLoadError(f"{exc} ({listed})", user_traceback=exc.user_traceback) from None
    return spec.invariants
