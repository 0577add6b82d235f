"""The random source of replay: it hands back the values recorded in RN_t; drawing more,
fewer, a different kind or with different parameters than was recorded is a mismatch
that names the behavior, or, in living replay, a difference noted for the verdict."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from operator import attrgetter
from typing import Any, NamedTuple

from beatlog.log.format import Draw
from beatlog.model.draws import (
    ARRAY_KINDS,
    SCALAR_VALUES,
    DrawKind,
    need_numpy,
    pack_array,
    same_params,
    unpack_array,
)
from beatlog.model.luck import FreshLuck, Luck, Place, array_value, scalar_luck, scalar_value
from beatlog.model.source import RandomSource

__all__ = ["DrawDifference", "RandomMismatch", "ReplayRandom"]

_RANDOM = DrawKind.RANDOM.value
_ACTOR = attrgetter("actor")
_made = tuple.__new__
"""A NamedTuple made of its fields in C, as its ``_make`` makes one without the Python
call its constructor costs: living replay makes two for most draws."""


class DrawDifference(NamedTuple):
    """A draw that living replay made otherwise than recorded (see
    :meth:`ReplayRandom.live`): re-mapped, new, or a recorded one left unused."""

    behavior: str
    """The behavior that drew it (that drew it in the recording, for one left unused),
    by its name now."""
    recorded: str | None
    """The recorded request as code (``uniform(0.8, 1.6)``; the kind alone in format 1);
    None for a draw the recording does not have."""
    asked: str | None
    """The request now; None for a recorded draw left unused."""

    def __str__(self) -> str:
        if self.recorded is None:
            return f"{self.behavior}: new {self.asked}"
        if self.asked is None:
            return f"{self.behavior}: {self.recorded} left unused"
        return f"{self.behavior}: {self.recorded} -> {self.asked}"


class RandomMismatch(BaseException):
    """Raised inside behavior code when a replayed draw does not match the recording.

    It derives from BaseException so that a behavior's ``except Exception`` cannot
    swallow it; the source also remembers the mismatch in case it is swallowed anyway.
    """

    def __init__(self, problem: str, actor: int, *, overdrawn: bool) -> None:
        super().__init__(problem)
        self.problem = problem
        self.actor = actor
        self.overdrawn = overdrawn


class ReplayRandom(RandomSource):
    """Returns the values recorded in RN_t, checking count, kind and parameters as it goes.

    Parameters are compared exactly, as numbers (``uniform(2, 5)`` asks for what
    ``uniform(2.0, 5.0)`` does, and draws the same); a format-1 draw, which recorded
    none, is checked for count and kind only. In *living* replay (:meth:`live`) a draw
    that differs is no mismatch: replay goes on with a value as lucky as the recorded
    one, and the difference is noted for the verdict to judge (:meth:`settle`).
    """

    def __init__(self) -> None:
        super().__init__()
        self.recorded: Sequence[Draw] = ()
        self.drawn: list[Draw] = []
        self.mismatch: RandomMismatch | None = None
        self.living = False
        """Whether draws that differ from the recording go on (:meth:`live`)."""
        self.differences: list[DrawDifference] = []
        """In living replay, the cycle's draws made otherwise than recorded."""
        self._actors: Sequence[int | None] | None = None
        self._recorded_names: Sequence[str] = ()
        self._names_now: Sequence[str] = ()
        self._recorded_now: Sequence[str] = ()
        self._fresh = FreshLuck(b"")
        self._used: list[bool] | None = None
        """In living replay, once a draw differed: which recorded draws are taken."""
        self._owner_of: dict[int, int | None] | None = None
        """The behavior each recorded actor is now, by its index (None: one the system
        no longer has), once :meth:`expect_actors` says so; the system stays -1."""
        self._owners: list[int | None] = []
        """Once a draw differed: the behavior that made each recorded draw, by its index now."""

    def expect_actors(
        self,
        recorded: Sequence[str],
        system: Sequence[str],
        rename: Callable[[str], str] = str,
    ) -> None:
        """Check which behavior draws, too: ``recorded`` is the log's catalogue,
        ``system`` the system's, and ``rename`` maps a recorded name to its name now. A
        draw recorded by a behavior the system no longer has is checked for kind and
        parameters only (in living replay, it is left unused)."""
        ids = {name: index for index, name in enumerate(system)}
        self._actors = [ids.get(rename(name)) for name in recorded]
        self._owner_of = {-1: -1, **dict(enumerate(self._actors))}
        self._recorded_names = recorded
        self._names_now = system
        self._recorded_now = [rename(name) for name in recorded]

    def live(self, key: bytes) -> None:
        """Go on when the behaviors ask for other draws than were recorded.

        A behavior's draws are matched with the draws it made in the recording, in
        order, a request of the same kind first: a recorded draw asked for with other
        parameters (or, where sound, as another kind) gives the value with its luck
        (:mod:`beatlog.model.luck`); a request with no recorded draw left gets a fresh
        one keyed by ``key`` (the log) and its place; recorded draws left over are
        dropped. Each is a :class:`DrawDifference`. Same log, same code: same draws.
        """
        self.living = True
        self._fresh = FreshLuck(key)

    def load(self, recorded: Sequence[Draw]) -> None:
        """Set the draws recorded for the next cycle."""
        self.recorded = recorded
        if self.drawn:
            self.drawn = []
        if self.differences:
            self.differences = []
        self._used = None
        self.mismatch = None

    def settle(self) -> list[DrawDifference]:
        """In living replay, once the cycle's update is over: its differences, the
        recorded draws left unused among them."""
        used = self._used
        if used is None and len(self.drawn) >= len(self.recorded):  # drew as recorded
            return self.differences
        start = len(self.drawn) if used is None else 0
        for index in range(start, len(self.recorded)):
            if used is None or not used[index]:
                draw = self.recorded[index]
                difference = (self._recorded_name(draw.actor), _request(draw), None)
                self.differences.append(_made(DrawDifference, difference))
        return self.differences

    def _recorded_name(self, actor: int) -> str:
        if actor < 0:
            return "system"
        names = self._recorded_now
        return names[actor] if actor < len(names) else f"#{actor}"

    def _strict(self, kind: DrawKind, params: tuple[Any, ...]) -> Any:
        """The recorded draw, checked against the request: any difference is a mismatch."""
        index = len(self.drawn)
        actor = self._actor
        name = kind._value_
        if index >= len(self.recorded):
            asked = Draw(actor, name, None, params)
            self._fail(
                f"called {asked.call()} (#{index + 1}) but only {index} were recorded",
                actor,
                overdrawn=True,
                asked=asked,
            )
        draw = self.recorded[index]
        if draw.kind != name or (draw.params and not same_params(draw.params, params)):
            asked = Draw(actor, name, None, params)
            recorded = draw.call() if draw.params else draw.kind  # format 1 recorded no params
            self._fail(f"called {asked.call()} where {recorded} was recorded", actor, asked=asked)
        if self._actors is not None and draw.actor != actor:
            self._check_actor(draw, actor, kind, params)
        self.drawn.append(Draw(actor, name, draw.value, params))
        return draw.value

    def _living(self, kind: DrawKind, params: tuple[Any, ...]) -> Any:
        """A draw in living replay: the recorded one while the cycle follows the
        recording, else the behavior's match (:meth:`live`). Most of a changed
        behavior's draws come here; written out flat, as each call costs."""
        name = kind._value_
        actor = -1 if self._context is None else self._context.actor
        recorded = self.recorded
        drawn = self.drawn
        used = self._used
        if used is None:
            index = len(drawn)
            if index < len(recorded):
                draw = recorded[index]
                if draw.kind == name and (not draw.params or same_params(draw.params, params)):
                    owner_of = self._owner_of
                    owner = draw.actor if owner_of is None else owner_of.get(draw.actor)
                    if owner == actor:  # the recording credits it to this behavior
                        drawn.append(_made(Draw, (actor, name, draw.value, params)))
                        return draw.value
            taken = min(index, len(recorded))
            used = self._used = [True] * taken + [False] * (len(recorded) - taken)
            owner_of = self._owner_of
            actors = map(_ACTOR, recorded)
            self._owners = list(actors if owner_of is None else map(owner_of.get, actors))
        owners = self._owners
        match = -1  # the behavior's first recorded draw left of the kind asked for
        for i, owner in enumerate(owners):
            if owner == actor and not used[i] and recorded[i].kind == name:
                match = i
                break
        else:
            if name in SCALAR_VALUES:  # else of another kind, its luck re-mapped
                for i, owner in enumerate(owners):
                    if owner == actor and not used[i] and _luck(recorded[i]) is not None:
                        match = i
                        break
        names = self._names_now
        behavior = "system" if actor < 0 else names[actor] if actor < len(names) else f"#{actor}"
        if match < 0:
            value = self._fresh_value(name, params, None, behavior, actor)
            asked = _made(Draw, (actor, name, value, params))
            self.differences.append(_made(DrawDifference, (behavior, None, asked.call())))
        else:
            used[match] = True
            draw = recorded[match]
            if draw.kind == name and (not draw.params or same_params(draw.params, params)):
                value = draw.value  # as recorded, in another place
                asked = _made(Draw, (actor, name, value, params))
            else:
                luck = None if name in ARRAY_KINDS else _luck(draw)
                value = (
                    scalar_value(name, params, luck)
                    if luck is not None
                    else self._fresh_value(name, params, draw, behavior, actor)
                )
                asked = _made(Draw, (actor, name, value, params))
                difference = (behavior, _request(draw), asked.call())
                self.differences.append(_made(DrawDifference, difference))
        drawn.append(asked)
        return value

    def _fresh_value(
        self, name: str, params: tuple[Any, ...], draw: Draw | None, behavior: str, actor: int
    ) -> Any:
        """The value of a request with fresh luck, keyed by its place; an array's with
        the luck of the recorded ``draw`` where it has one."""
        cycle = self._context.cycle if self._context is not None else -1
        place = _made(Place, (cycle, behavior, list(map(_ACTOR, self.drawn)).count(actor)))
        if name in ARRAY_KINDS:
            old = None
            if draw is not None and draw.params:
                old = (draw.kind, draw.params, unpack_array(draw.value))
            return pack_array(array_value(name, params, old, self._fresh.seed(place)))
        return scalar_value(name, params, self._fresh.luck(place))

    def _check_actor(self, draw: Draw, actor: int, kind: DrawKind, params: tuple[Any, ...]) -> None:
        """Refuse a draw the recording credits to another behavior (by its name now)."""
        assert self._actors is not None
        recorded = draw.actor
        if recorded < 0:
            expected: int | None = -1
            who = "the system"
        elif recorded < len(self._actors):
            expected = self._actors[recorded]
            who = self._recorded_names[recorded]
        else:
            return
        if expected is not None and expected != actor:
            asked = Draw(actor, kind.value, None, params)
            self._fail(
                f"called {asked.call()}, which {who} drew in the recording", actor, asked=asked
            )

    def _fail(
        self, problem: str, actor: int, *, overdrawn: bool = False, asked: Draw | None = None
    ) -> None:
        """Raise (and remember) a mismatch; ``asked``, a draw refused, is kept among those
        drawn, with no value, so reports show what was asked for."""
        if asked is not None:
            self.drawn.append(asked)
        self.mismatch = RandomMismatch(problem, actor, overdrawn=overdrawn)
        raise self.mismatch

    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any:
        value = self._living(kind, params) if self.living else self._strict(kind, params)
        if kind is DrawKind.CHOICE and not 0 <= value < b:
            self._fail(
                f"recorded choice index {value} is out of range for {int(b)} items", self._actor
            )
        return value

    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any:
        need_numpy()  # before a fresh draw of living replay, too
        params = (a, b, list(shape))
        draw = self._living if self.living else self._strict
        array = unpack_array(draw(kind, params))
        if array.shape != shape:
            self._fail(
                f"drew {kind.value} of shape {shape} where {array.shape} was recorded", self._actor
            )
        return array


def _request(draw: Draw) -> str:
    """A recorded draw's request as code; the kind alone where format 1 recorded none."""
    return draw.call() if draw.params else draw.kind


def _luck(draw: Draw) -> Luck | None:
    """The luck of a recorded scalar draw, where it can be known."""
    if draw.kind == _RANDOM:
        return scalar_luck(draw.kind, draw.value, ())
    return scalar_luck(draw.kind, draw.value, draw.params) if draw.params else None
