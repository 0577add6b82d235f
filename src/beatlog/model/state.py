"""The robot state RS: a light, typed store of the latest sensor data and derived variables."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import msgspec

__all__ = ["RobotState", "state_fields", "state_schema", "state_type_name"]


class RobotState(msgspec.Struct, kw_only=True):
    """Base for a robot's state struct; subclass it with typed fields.

    Keep it light, as the paper asks: a brightness level, not the camera image.
    Fields need defaults if logs recorded before the field existed must still load.

    A wide state (hundreds of fields) is best built positionally, ``Wide(*values)`` in
    field order (a subclass declared without ``kw_only=True``), or by
    ``msgspec.convert(values_by_name, Wide)``: by keyword arguments its cost grows with
    the square of its width (3 ms at 1,000 fields, against 6 µs positionally).
    """


def state_schema(state_type: type[msgspec.Struct]) -> dict[str, Any]:
    """The JSON schema of a robot state type, embedded in every session log header."""
    return msgspec.json.schema(state_type)


def state_type_name(state_type: type[Any]) -> str:
    """The dotted name of a robot state type, for headers and messages: a type defined
    in the script being run (``__main__``) is named by the module that script is when
    imported, as replay meets it (``vacuum.VacState``), where there is one."""
    module = state_type.__module__
    if module == "__main__":
        module = _main_module() or module
    return f"{module}.{state_type.__qualname__}"


def _main_module() -> str | None:
    """The name under which the script being run can be imported: the module ``python
    -m`` ran, or the script's path below the first folder of ``sys.path`` that holds it;
    None when there is none (an interactive session, a script outside ``sys.path``)."""
    main = sys.modules.get("__main__")
    spec = getattr(main, "__spec__", None)
    if spec is not None and spec.name and spec.name != "__main__":
        return str(spec.name)
    script = getattr(main, "__file__", None)
    if not script:
        return None
    path = Path(script).resolve()
    for folder in sys.path:
        try:
            parts = path.with_suffix("").relative_to(Path(folder or ".").resolve()).parts
        except ValueError:
            continue
        if path.suffix == ".py" and parts and all(part.isidentifier() for part in parts):
            return ".".join(parts)
    return None


def state_fields(state_type: type[Any]) -> list[str]:
    """The fields a robot state type encodes as a map, in order (their encoded names);
    none for a type that does not encode as one (not a struct, or ``array_like``)."""
    config = getattr(state_type, "__struct_config__", None)
    if config is None or config.array_like:
        return []
    return list(state_type.__struct_encode_fields__)
