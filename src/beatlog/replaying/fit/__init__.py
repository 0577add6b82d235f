"""The fit step: whether a session log fits the system it is replayed against.

A log fits when its robot state is the system's: the same type (its module may have
moved; a type renamed since keeps exactly its fields), every robot-state field it
recorded in the system's state with a type that holds the recorded values (the same,
or a wider one: an int that became a float, a type that became optional, a nested
struct that gained fields with defaults), and every field the system's state added
since with a default. A field renamed or retyped otherwise since the recording is
mapped by a :class:`~beatlog.replaying.fit.migration.StateMigration` the user gives (a
spec's ``field_renames`` and ``field_conversions``); one that is not leaves a message
proposing the rename. Anything else would replay on a state silently filled with
defaults, so it is bad input, never a verdict. The same goes for a log none of whose
behaviors is the system's (:func:`check_catalogue`): another robot's log. A behavior
the system lacks among others is a verdict, with rename proposals, because behavior
changes are what DTCs exist to catch.

:mod:`.check` words the misfits; :mod:`.schema` says how two robot-state schemas
differ and gives the system's robot state type as the log's cycles must hold it
(:func:`recorded_state_type`); :mod:`.migration` maps fields renamed or retyped since
the recording. The names are imported on first use.
"""

from typing import TYPE_CHECKING

from beatlog.log._lazy import lazy_names

if TYPE_CHECKING:
    from beatlog.replaying.fit.check import check_catalogue as check_catalogue
    from beatlog.replaying.fit.check import check_fit as check_fit
    from beatlog.replaying.fit.check import check_state_fields as check_state_fields
    from beatlog.replaying.fit.check import period_note as period_note
    from beatlog.replaying.fit.check import state_differences as state_differences
    from beatlog.replaying.fit.migration import StateConverter as StateConverter
    from beatlog.replaying.fit.migration import StateMigration as StateMigration
    from beatlog.replaying.fit.schema import recorded_state_type as recorded_state_type

__getattr__ = lazy_names(__name__)
