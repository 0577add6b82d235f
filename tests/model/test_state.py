"""The robot state type: a wide state built positionally, in time linear in its width,
is the state built by keywords, to the byte; a type is named as replay imports it."""

from __future__ import annotations

import importlib.machinery
import sys
import types
from pathlib import Path

import msgspec
import pytest

from beatlog.log.format import payload_encoder
from beatlog.model.state import RobotState, state_type_name

FIELDS = [(f"reading_{index:03d}", float, 0.0) for index in range(300)]
Wide = msgspec.defstruct("Wide", FIELDS, bases=(RobotState,))
WideByName = msgspec.defstruct("WideByName", FIELDS, bases=(RobotState,), kw_only=True)


def test_a_wide_state_built_positionally_is_the_one_built_by_keywords() -> None:
    values = [index / 7 for index in range(len(FIELDS))]
    by_name = dict(zip(Wide.__struct_fields__, values, strict=True))
    positional = Wide(*values)
    assert positional == Wide(**by_name) == msgspec.convert(by_name, Wide)
    encode = payload_encoder().encode
    assert (
        encode(positional)
        == encode(WideByName(**by_name))
        == encode(msgspec.convert(by_name, WideByName))
    )


def test_only_a_state_declared_without_kw_only_takes_its_fields_by_position() -> None:
    with pytest.raises(TypeError, match="Extra positional arguments provided"):
        WideByName(1.0)


def _run_as_main(monkeypatch: pytest.MonkeyPatch, script: Path | None, spec: str | None) -> type:
    """A state class defined in a script run as ``__main__`` (``python script.py`` or,
    with ``spec``, ``python -m spec``)."""
    main = types.ModuleType("__main__")
    main.__spec__ = None if spec is None else importlib.machinery.ModuleSpec(spec, None)
    if script is not None:
        main.__file__ = str(script)
    monkeypatch.setitem(sys.modules, "__main__", main)
    return type("VacState", (RobotState,), {"__module__": "__main__"})


def test_a_state_class_of_the_script_run_is_named_as_the_script_imports(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.syspath_prepend(str(tmp_path))
    state = _run_as_main(monkeypatch, tmp_path / "robots" / "vacuum.py", spec=None)

    assert state_type_name(state) == "robots.vacuum.VacState"


def test_a_state_class_of_a_module_run_with_dash_m_is_named_by_the_module(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    state = _run_as_main(monkeypatch, None, spec="robots.vacuum")

    assert state_type_name(state) == "robots.vacuum.VacState"


def test_a_state_class_of_a_script_that_cannot_be_imported_keeps_main(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    state = _run_as_main(monkeypatch, tmp_path / "vacuum.py", spec=None)

    assert state_type_name(state) == "__main__.VacState"
