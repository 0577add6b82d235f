"""Adapters between beatlog and the tools robotics teams already use, each in its own
module that imports its tool only when used (``import beatlog`` needs none of them):
:mod:`beatlog.adapters.py_trees` (a behaviour tree as a system),
:mod:`beatlog.adapters.rosbag` (a ROS bag as a session log with samples) and
:mod:`beatlog.adapters.export` (MCAP for Foxglove and Lichtblick, Parquet, CSV).
"""

__all__: list[str] = []
