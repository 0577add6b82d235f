"""The fit step: whether a session log fits the system it is replayed against.

A log fits when its robot state is the system's: the same type (its module may have
moved; a type renamed since keeps exactly its fields), every field it recorded held by
a field of the same or a wider type, and every field added since with a default. A
field renamed or retyped otherwise is mapped by a
:class:`~beatlog.replay.fit.migration.StateMigration` the user gives; anything else
would replay on a state silently filled with defaults, so it is bad input, never a
verdict. So is a log none of whose behaviors is the system's: another robot's log. A
behavior the system lacks among others is a verdict, since behavior changes are what
DTCs exist to catch.

:mod:`.check` words the misfits, :mod:`.schema` compares the two robot-state schemas and
gives the type the log's cycles must fit, :mod:`.migration` maps renamed or retyped fields.
"""
