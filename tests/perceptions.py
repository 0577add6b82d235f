"""Perception steps the tests replay from samples, and probe sessions recorded with them.

Specs and ``--perception`` name them as ``tests.perceptions:FACTORY``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from beatlog.model.inbox import Sample
from beatlog.model.perception import Perception
from beatlog.record.recorder import Recorder
from tests.conftest import PERIOD_NS, Probe, distances, probe_system
from tests.systems import Ranged

PERCEPTION = "tests.perceptions:perception"
CHANGED = "tests.perceptions:changed_perception"
CHANGED_AGAIN = "tests.perceptions:changed_again_perception"
ONE_ULP = "tests.perceptions:one_ulp_perception"
ULP_CYCLE = 95
"""The one cycle where :func:`one_ulp_perception` reads the range otherwise than
:func:`changed_perception`: one the changed perception rebuilds otherwise too."""


def perceive(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
    """The probe's perception: the last range reading is the distance."""
    state = Probe() if previous is None else previous
    for sample in samples:
        if sample.sensor == "range":
            state = Probe(distance=sample.value[0], reading=state.reading)
    return state


def perception() -> Perception:
    return perceive


def _scaled(factor: float, *, from_distance: float) -> Perception:
    def scaled(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        distance = state.distance
        return Probe(distance=distance * factor if distance >= from_distance else distance)

    return scaled


def changed_perception() -> Perception:
    """A perception change: the range is read 10 % long from a distance of 0.8 on."""
    return _scaled(1.1, from_distance=0.8)


def changed_again_perception() -> Perception:
    """Another perception change: the range is read 20 % long from a distance of 0.8 on."""
    return _scaled(1.2, from_distance=0.8)


def one_ulp_perception() -> Perception:
    """The changed perception, but one ulp longer in cycle :data:`ULP_CYCLE` alone."""
    changed = changed_perception()

    def one_ulp(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state: Probe = changed(previous, samples)
        if any(sample.stamp_ns == ULP_CYCLE * PERIOD_NS for sample in samples):
            return Probe(distance=math.nextafter(state.distance, math.inf), reading=state.reading)
        return state

    return one_ulp


def nudged_perception() -> Perception:
    """A perception change far below any sensor's noise: the range is read 1e-9 long."""

    def nudged(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        return Probe(distance=state.distance + 1e-9, reading=state.reading)

    return nudged


def shifted_perception() -> Perception:
    """The range is read 0.05 short: near enough to the threshold to change behavior."""

    def shifted(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        return Probe(distance=state.distance - 0.05, reading=state.reading)

    return shifted


def dict_perception() -> Perception:
    """Builds the probe's fields as a dict, which encodes as the probe does."""

    def as_dict(previous: Probe | None, samples: Sequence[Sample]) -> dict[str, float]:
        state = perceive(previous, samples)
        return {"distance": state.distance, "reading": state.reading}

    return as_dict


def numpy_perception() -> Perception:
    """A perception change that computes the distance with numpy, as a float32."""

    def computed(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        state = perceive(previous, samples)
        distance = np.float32(state.distance) * 2
        return Probe(distance=distance, reading=state.reading)  # type: ignore[arg-type]

    return computed


def ranged_perception() -> Perception:
    """The probe's perception for its state whose ``distance`` is now ``range``."""

    def ranged(previous: Ranged | None, samples: Sequence[Sample]) -> Ranged:
        before = None if previous is None else Probe(distance=previous.range)
        state = perceive(before, samples)
        return Ranged(range=state.distance, reading=state.reading)

    return ranged


def broken_perception() -> Perception:
    def broken(previous: Probe | None, samples: Sequence[Sample]) -> Probe:
        if previous is not None and previous.distance < 0.5:
            raise ValueError("no range sensor")
        return perceive(previous, samples)

    return broken


def record_with_samples(
    path: Path, cycles: int = 300, *, log_samples: bool = True, by_field: bool | None = None
) -> Path:
    """A probe session whose robot state is perceived from one range sample a cycle
    (its robot states stored by field where ``by_field``)."""
    state: Probe | None = None
    with Recorder(
        path, probe_system(), seed=3, software="test", log_samples=log_samples, by_field=by_field
    ) as recorder:
        for t, distance in enumerate(distances(cycles)):
            samples = [Sample("range", t * PERIOD_NS, (distance, 1))]
            state = perceive(state, samples)
            recorder.step(PERIOD_NS, state, samples)
    return path
