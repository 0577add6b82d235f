"""When baselines may be written: the update mode, validated like vcrpy's record modes,
the CI rule that overrides every mode, and the open-loop limits that make a suite stale."""

from __future__ import annotations

import pytest

from beatlog.baseline.policy import (
    StaleSuite,
    UpdateMode,
    in_ci,
    open_loop_share,
    refusal,
    require_writable,
    stale_suite,
)
from beatlog.errors import CiWriteError, OptionError
from beatlog.replay.verdict import Divergence, DivergenceKind


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


SHARES = [("dock", 0.0), ("held-back", 0.75), ("imu-late", 0.74), ("escape", 0.42), ("yard", 0.1)]
"""DTCs with the share of their cycles each runs open loop."""


def test_a_suite_within_its_open_loop_limits_is_not_stale() -> None:
    assert stale_suite(SHARES, max_share=None, max_dtcs=None) is None
    assert stale_suite(SHARES, max_share=0.8, max_dtcs=4) is None


def test_the_dtcs_over_the_share_come_first_to_re_record_most_open_loop_first() -> None:
    stale = stale_suite(SHARES, max_share=0.5, max_dtcs=None)

    assert stale == StaleSuite(4, 2, (("held-back", 0.75), ("imu-late", 0.74)), 0.5, None)


def test_too_many_open_loop_dtcs_name_as_many_to_re_record_as_are_too_many() -> None:
    assert stale_suite(SHARES, max_share=None, max_dtcs=2) == StaleSuite(
        4, 0, (("held-back", 0.75), ("imu-late", 0.74)), None, 2
    )
    assert stale_suite(SHARES, max_share=0.5, max_dtcs=1) == StaleSuite(
        4, 2, (("held-back", 0.75), ("imu-late", 0.74), ("escape", 0.42)), 0.5, 1
    )


def test_the_open_loop_share_is_of_the_cycles_from_the_open_loop_on() -> None:
    assert [open_loop_share(300, cycle) for cycle in (None, 0, 75, 300)] == [0.0, 1.0, 0.75, 0.0]


@pytest.mark.parametrize(
    ("kind", "refused"),
    [
        (DivergenceKind.STATE_CHANGES, None),
        (DivergenceKind.OUTPUTS, None),
        (DivergenceKind.RANDOM_OVERDRAWN, None),
        (DivergenceKind.RANDOM_UNDERDRAWN, None),
        (DivergenceKind.RANDOM_MISMATCH, None),
        (DivergenceKind.EXCEPTION, "a behavior raised: an exception is a bug, never a baseline"),
        (DivergenceKind.LOG_ENDED, "a divergence in log ended cannot be re-baselined"),
        (DivergenceKind.PERCEPTION, "perception raised or built no robot state"),
        (DivergenceKind.INVARIANT, "an invariant does not hold: a violation is a bug"),
    ],
)
def test_what_a_baseline_can_hold_and_what_needs_a_fix_or_a_recording(
    kind: DivergenceKind, refused: str | None
) -> None:
    why = refusal(Divergence(kind, 3, 90_000_000, "differs"))

    if refused is None:
        assert why is None
    else:
        assert why is not None
        assert why.startswith(refused)
