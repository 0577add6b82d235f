"""Adapters between beatlog and the tools robotics teams already use.

Each adapter is its own module and imports its tool only when it is used, so
``import beatlog`` never needs them: :mod:`beatlog.adapters.py_trees` records and
replays a py_trees behaviour tree (``pip install 'beatlog[py-trees]'``);
:mod:`beatlog.adapters.export` writes a session log as MCAP with JSON payloads for
Foxglove and Lichtblick (with Foxglove's well-known schemas where it has one), or as a
table (Parquet, CSV) for analysis;
:mod:`beatlog.adapters.rosbag` imports a ROS bag as a session log with samples, a DTC
replayed at sensor level (``pip install 'beatlog[ros]'``).
"""

__all__: list[str] = []
