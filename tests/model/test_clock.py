"""Heartbeat clocks: exact simulated time, and a live timer that measures and never drifts."""

from __future__ import annotations

import time

import pytest

from beatlog.model.clock import LiveHeartbeat, SimulatedHeartbeat

PERIOD = 30_000_000


class FakeTime:
    """Stands in for time.monotonic_ns and time.sleep so the live clock runs on our time."""

    def __init__(self) -> None:
        self.now = 1_000_000_000
        self.lag = 0

    def monotonic_ns(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += round(seconds * 1e9) + self.lag


@pytest.fixture
def fake_time(monkeypatch: pytest.MonkeyPatch) -> FakeTime:
    fake = FakeTime()
    monkeypatch.setattr(time, "monotonic_ns", fake.monotonic_ns)
    monkeypatch.setattr(time, "sleep", fake.sleep)
    return fake


def test_simulated_time_is_the_exact_sum_of_intervals() -> None:
    clock = SimulatedHeartbeat()
    times = [clock.advance(interval) for interval in (30_000_001, 29_999_999, 31_234_567)]
    assert times == [30_000_001, 60_000_000, 91_234_567]
    assert clock.now_ns == 30_000_001 + 29_999_999 + 31_234_567


def test_live_beats_come_one_period_apart(fake_time: FakeTime) -> None:
    clock = LiveHeartbeat(PERIOD)
    clock.start()
    intervals = [clock.wait() for _ in range(5)]
    assert intervals == [PERIOD] * 5
    assert clock.now_ns == 5 * PERIOD
    assert clock.overruns == 0


def test_a_late_wakeup_is_measured_in_the_interval(fake_time: FakeTime) -> None:
    clock = LiveHeartbeat(PERIOD)
    clock.start()
    fake_time.lag = 700_000
    assert clock.wait() == PERIOD + 700_000


def test_an_overrun_is_counted_and_later_beats_stay_on_the_grid(fake_time: FakeTime) -> None:
    clock = LiveHeartbeat(PERIOD)
    clock.start()
    start = fake_time.now
    clock.wait()
    fake_time.now += 45_000_000  # the cycle's work took 1.5 periods
    late = clock.wait()
    assert clock.overruns == 1
    assert late == 45_000_000 + 15_000_000  # resumes at the next grid point, 3 periods in
    clock.wait()
    assert (fake_time.now - start) % PERIOD == 0
    assert clock.now_ns == fake_time.now - start


def test_period_must_be_positive() -> None:
    with pytest.raises(ValueError, match="positive"):
        LiveHeartbeat(0)
