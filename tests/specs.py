"""DTC specs written by the tests: ``write_spec``, the system references they name, and
baseline files written by hand in any format (``baseline_file``)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from beatlog.model.behavior import System
from beatlog.record.recorder import Recorder
from beatlog.suite.spec import DtcSpec, load_spec
from tests.conftest import PERIOD_NS, Probe, distances, probe_system
from tests.systems import Rover, rover_system

PROBE = "tests.conftest:probe_system"
CHANGED = "tests.conftest:probe_system_changed"
GAUGE = "tests.systems:gauge_system"
"""The system of the logs :mod:`tests.crafting` crafts."""
ROVER = "tests.systems:rover_system"
"""Another robot, whose behaviors have the probe's names."""

FIRST_CHANGED_CYCLE = next(t for t, d in enumerate(distances(300)) if (d < 0.6) != (d < 0.5))
"""The first cycle where the changed probe's near behavior sees the obstacle first."""
PROBE_CHECKED = "300 cycles, 45 state changes, 453 outputs, 60 draws checked; 9.0 s robot time"
"""What a replay of a probe log of 300 cycles checks, as ``beatlog replay`` says it."""


def toml_value(value: object) -> str:
    """Enough TOML for specs: booleans, numbers, strings, arrays and inline tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a TOML basic string for everything a test writes
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    if isinstance(value, dict):
        items = (f"{json.dumps(key)} = {toml_value(item)}" for key, item in value.items())
        return "{ " + ", ".join(items) + " }"
    raise TypeError(f"no TOML for {value!r}")


def write_spec(
    folder: Path,
    name: str,
    log: Path | str,
    system: str = PROBE,
    /,
    **extra: object,
) -> Path:
    """Write ``<folder>/<name>.dtc.toml`` and return its path.

    A ``Path`` log is written relative to the spec's folder, as a user would; a ``str``
    log is written verbatim. ``extra`` adds or replaces keys (even ``name``, ``log`` and
    ``system``); ``None`` leaves a key out.
    """
    folder.mkdir(parents=True, exist_ok=True)
    keys: dict[str, object] = {
        "name": name,
        "purpose": f"The probe replays {name} as recorded.",
        "procedure": ["Drive the probe toward the pole and back, twice."],
        "log": os.path.relpath(log, folder) if isinstance(log, Path) else log,
        "system": system,
        **extra,
    }
    path = folder / f"{name}.dtc.toml"
    path.write_text(
        "".join(
            f"{key} = {toml_value(value)}\n" for key, value in keys.items() if value is not None
        ),
        encoding="utf-8",
    )
    return path


def two_robots(root: Path) -> dict[str, Path]:
    """A repository of two robots, each with a folder of DTCs and no ``pyproject.toml``
    of its own; every DTC's log lies beside its spec. The probe has ``approach`` (it
    goes near the pole) and ``low-battery`` (it stays far), the rover ``low-battery``
    (it goes near): both have a ``near`` behavior. Returns the specs by id."""
    (root / "pyproject.toml").write_text('[project]\nname = "robots"\n', encoding="utf-8")
    dtcs = [
        ("probe", "approach", PROBE, True),
        ("probe", "low-battery", PROBE, False),
        ("rover", "low-battery", ROVER, True),
    ]
    specs = {}
    for robot, name, system, near in dtcs:
        folder = root / robot / "dtc"
        folder.mkdir(parents=True, exist_ok=True)
        made = rover_system() if system == ROVER else probe_system()
        state = Rover if system == ROVER else Probe
        log = _record(folder / f"{name}.beatlog", made, system, state, near=near)
        specs[f"{robot}/dtc/{name}.dtc.toml::{name}"] = write_spec(folder, name, log, system)
    return specs


def _record(
    log: Path, system: System, reference: str, state: type[Probe | Rover], *, near: bool
) -> Path:
    """Record ``system``: towards the pole and back twice (200 cycles), or far from it."""
    profile = distances(200) if near else [2.0] * 40
    with Recorder(log, system, seed=7, software="test", system_ref=reference) as recorder:
        for distance in profile:
            recorder.step(PERIOD_NS, state(distance=distance))
    return log


def written_dtc(
    folder: Path, name: str, log: Path | str, system: str = PROBE, /, **extra: object
) -> DtcSpec:
    """Write a spec (see :func:`write_spec`) and load it back, as discovery would."""
    return load_spec(write_spec(folder, name, log, system, **extra))


BASELINE_MAGIC = {
    1: "# beatlog expected state changes, format 1",
    2: "# beatlog expected state changes and outputs, format 2",
    3: "# beatlog expected state changes, outputs and robot states, format 3",
    4: "# beatlog expected state changes, outputs, robot states and draws, format 4",
    5: "# beatlog expected departures from the recording, format 5",
    6: "# beatlog expected departures from the recording, format 6",
    7: "# beatlog expected departures from the recording, format 7",
}
"""The first line of a baseline file of each format."""


def baseline_file(
    folder: Path, version: int, *lines: str, name: str = "a", spec: bool = False
) -> Path:
    """A baseline file ``NAME.dtc.expected`` in ``folder`` as format ``version`` starts one
    (with a ``# spec NAME`` line where ``spec``), for a log ``a.beatlog`` whose digest is
    all zeros, holding ``lines`` after its header."""
    header = [BASELINE_MAGIC[version], *([f"# spec {name}"] if spec else [])]
    path = folder / f"{name}.dtc.expected"
    text = "\n".join([*header, f"# log a.beatlog sha256 {'0' * 64}", *lines])
    path.write_text(f"{text}\n", encoding="utf-8")
    return path
