"""The user's project: its configuration (``[tool.beatlog]``, :mod:`.config`), its code,
the systems, robots and perceptions beatlog builds from it (:mod:`.usercode`), and the
leak watch that names where that code reads the wall clock or a global random
generator (:mod:`.leaks`)."""
