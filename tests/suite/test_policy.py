"""When baselines may be written: the update mode, validated like vcrpy's record modes,
and the CI rule that overrides every mode."""

from __future__ import annotations

import pytest

from beatlog.errors import CiWriteError, OptionError
from beatlog.suite.policy import UpdateMode, in_ci, require_writable


@pytest.mark.parametrize("mode", list(UpdateMode))
def test_every_update_mode_is_parsed_from_its_name(mode: UpdateMode) -> None:
    assert UpdateMode.parse(mode.value) is mode
    assert UpdateMode.parse(mode) is mode


def test_an_unknown_update_mode_names_the_modes_there_are() -> None:
    with pytest.raises(OptionError) as raised:
        UpdateMode.parse("always")
    assert str(raised.value) == "unknown update mode 'always': choose one of 'none', 'new'"


@pytest.mark.parametrize(
    ("value", "ci"),
    [(None, False), ("", False), ("0", False), ("false", False), ("true", True), ("1", True)],
)
def test_ci_is_recognised_from_the_environment(
    monkeypatch: pytest.MonkeyPatch, value: str | None, *, ci: bool
) -> None:
    if value is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", value)
    assert in_ci() is ci


def test_nothing_is_writable_in_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    require_writable()
    monkeypatch.setenv("CI", "true")
    with pytest.raises(CiWriteError, match="CI is set: beatlog never writes baselines in CI"):
        require_writable()
