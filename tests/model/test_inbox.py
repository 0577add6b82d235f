"""The sensor inbox collects samples from many driver threads between heartbeats."""

from __future__ import annotations

import threading

from beatlog.model.inbox import SensorInbox


def test_samples_from_concurrent_drivers_all_arrive_in_order_per_sensor() -> None:
    inbox = SensorInbox()
    per_driver = 2000

    def driver(name: str) -> None:
        for i in range(per_driver):
            inbox.push(name, i)

    threads = [threading.Thread(target=driver, args=(f"s{n}",)) for n in range(4)]
    collected = []
    for thread in threads:
        thread.start()
    while any(thread.is_alive() for thread in threads):
        collected.extend(inbox.drain())
    for thread in threads:
        thread.join()
    collected.extend(inbox.drain())
    for n in range(4):
        values = [s.value for s in collected if s.sensor == f"s{n}"]
        assert values == list(range(per_driver))
    assert inbox.drain() == []


def test_a_given_stamp_is_kept() -> None:
    inbox = SensorInbox()
    inbox.push("range", 1.5, stamp_ns=42)
    (sample,) = inbox.drain()
    assert sample == ("range", 42, 1.5)
