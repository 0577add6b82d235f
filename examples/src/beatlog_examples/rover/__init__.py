"""A small 2D rover: range sensors and a bumper in driver threads, and three behaviors.

- :mod:`~beatlog_examples.rover.world`: the arena and the rover's kinematics.
- :mod:`~beatlog_examples.rover.behaviors`: escape, avoid and wander (which is random).
- :mod:`~beatlog_examples.rover.robot`: the live robot (physics and driver threads),
  its perception step, and a lockstep simulation for recording long sessions fast.

Factories for the CLI: ``beatlog_examples.rover:system``, ``:changed_system`` (avoid
reacts 10 cm earlier: a deliberate behavior change) and ``:robot``.
"""

from beatlog_examples.rover.behaviors import RoverState, changed_system, system
from beatlog_examples.rover.robot import RoverRobot, record_lockstep, robot

__all__ = ["RoverRobot", "RoverState", "changed_system", "record_lockstep", "robot", "system"]
