"""What the dog's variants perturb: the ``[variants]`` table every spec of its suite
declares (:mod:`beatlog_examples.dog.record_suite` writes it), so that ``beatlog test
--variants N`` replays each recording N more times in situations its sessions did not
quite reach, judged by the dog's invariants (:mod:`beatlog_examples.dog.invariants`).

Noise goes only on the robot-state fields a behavior reads that a sensor measures, each
within what that sensor could report on top of what it did
(:mod:`beatlog_examples.dog.sensors`):

- ``range_left``, ``range_front``, ``range_right`` and ``nearest``: +-15 mm, three
  standard deviations of a range finder's noise (5 mm);
- ``tilt``: +-1 degree, about what the accelerometer's noise (0.05 m/s^2 a
  component) tilts gravity by;
- ``speed``: +-1 cm/s, leg odometry's slip on top of its 5 mm/s noise;
- ``knee_mean``: +-0.02 rad, two steps of the joint encoders' resolution;
- ``battery``: +-0.5 %, a fuel gauge's error;
- ``beacon_bearing``: +-0.05 rad, 2.5 standard deviations of the beacon's (0.02);
  ``beacon_distance``: +-2 cm.

Commands and what the dog says of itself (the motion module's report, the remote's
commands, touches, emotions) are not measured: they get no noise. Every random number
is drawn fresh, and each 30 ms heartbeat moves by up to +-3 ms, as a busy robot's
does. No ``count``: ``beatlog test`` runs the DTCs alone unless ``--variants`` asks
for variants.
"""

from __future__ import annotations

from typing import Any

__all__ = ["VARIANTS"]

VARIANTS: dict[str, Any] = {
    "draws": True,
    "heartbeat_jitter": 0.003,
    "noise": {
        "range_left": 0.015,
        "range_front": 0.015,
        "range_right": 0.015,
        "nearest": 0.015,
        "tilt": 1.0,
        "speed": 0.01,
        "knee_mean": 0.02,
        "battery": 0.5,
        "beacon_bearing": 0.05,
        "beacon_distance": 0.02,
    },
}
"""The dog's ``[variants]`` table, as a spec of its suite declares it."""
