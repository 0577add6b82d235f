"""The user's project: its configuration (``[tool.beatlog]``, :mod:`.config`) and its
code, the systems, robots and perceptions beatlog builds from it (:mod:`.usercode`)."""
