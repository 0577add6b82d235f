"""A simulated robot dog in MuJoCo with a behavior set like the AIBO's, and its DTC suite.

- :mod:`~beatlog_examples.dog.behaviors`: the robot state and twelve behaviors under a
  priority arbiter (no MuJoCo needed, so replay stays light).
- :mod:`~beatlog_examples.dog.world`, :mod:`~.gait`, :mod:`~.sensors`: the MuJoCo
  world (``arena.xml``, ``dog.xml``), the motion module and the sensor drivers.
- :mod:`~beatlog_examples.dog.robot`: the live robot; :mod:`~.remote`: remote
  control over loopback TCP; :mod:`~.scenarios`: the scripted human tester;
  :mod:`~.fastforward`: lockstep recording for long sessions;
  :mod:`~.record_suite`: re-records the suite in ``suite/``.

Factories for the CLI: ``beatlog_examples.dog:system``, ``:changed_system`` (avoid
reacts 10 cm earlier) and ``beatlog_examples.dog.robot:robot``.
"""

from pathlib import Path

from beatlog_examples.dog.behaviors import DogState, changed_system, system

__all__ = ["SUITE_DIR", "DogState", "changed_system", "system"]

SUITE_DIR = Path(__file__).with_name("suite")
"""The committed 22-DTC suite, shipped with the package."""
