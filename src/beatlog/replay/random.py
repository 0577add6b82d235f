"""The random source of replay: it hands back the values recorded in RN_t; drawing more,
fewer, a different kind or with different parameters than was recorded is a draw refused
that names the behavior, or, in replay matching draws, a draw made otherwise noted for
the verdict."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from beatlog.log.format import Draw
from beatlog.model.cycle import actor_name
from beatlog.model.draws import (
    ARRAY_KINDS,
    SCALAR_VALUES,
    DrawKind,
    need_numpy,
    pack_array,
    same_params,
    unpack_array,
)
from beatlog.model.quantiles import (
    FreshQuantiles,
    Place,
    Quantile,
    array_value,
    scalar_quantile,
    scalar_value,
)
from beatlog.model.source import RandomSource
from beatlog.replay.draws import DrawMadeOtherwise

__all__ = ["RefusedDraw", "ReplayRandom"]


class RefusedDraw(BaseException):
    """A draw refused: raised inside behavior code when a replayed draw does not match
    the recording.

    It derives from BaseException so that a behavior's ``except Exception`` cannot
    swallow it; the source also remembers the draw refused in case it is swallowed anyway.
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
    none, is checked for count and kind only. Replay matching draws
    (:meth:`match_draws`) refuses none: a draw made otherwise goes on with a value at
    the recorded one's quantile, and is noted for the verdict to judge (:meth:`settle`).
    """

    def __init__(self) -> None:
        super().__init__()
        self.recorded: Sequence[Draw] = ()
        self.drawn: list[Draw] = []
        self.refused: RefusedDraw | None = None
        self.matching = False
        """Whether draws made otherwise than recorded go on (:meth:`match_draws`)."""
        self.made_otherwise: list[DrawMadeOtherwise] = []
        """In replay matching draws, the cycle's draws made otherwise than recorded."""
        self._recorded_names: Sequence[str] = ()
        self._names_now: Sequence[str] = ()
        self._recorded_now: Sequence[str] = ()
        self._fresh = FreshQuantiles(b"")
        self._used: list[bool] | None = None
        """In replay matching draws, once a draw differed: which recorded draws are taken."""
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
        parameters only (in replay matching draws, it is left unused)."""
        ids = {name: index for index, name in enumerate(system)}
        self._recorded_names = recorded
        self._names_now = system
        self._recorded_now = [rename(name) for name in recorded]
        self._owner_of = {-1: -1, **{i: ids.get(name) for i, name in enumerate(self._recorded_now)}}

    def match_draws(self, key: bytes) -> None:
        """Go on when the behaviors ask for other draws than were recorded.

        A behavior's draws are matched with the draws it made in the recording, in
        order, a request of the same kind first: a recorded draw asked for with other
        parameters (or, where sound, as another kind) gives the value at its quantile
        (:mod:`beatlog.model.quantiles`); a request with no recorded draw left gets a
        fresh one keyed by ``key`` (the log) and its place; recorded draws left over are
        dropped. Each is a :class:`~beatlog.replay.draws.DrawMadeOtherwise`. Same log,
        same code: same draws.
        """
        self.matching = True
        self._fresh = FreshQuantiles(key)

    def load(self, recorded: Sequence[Draw]) -> None:
        """Set the draws recorded for the next cycle."""
        self.recorded = recorded
        self.drawn = []
        self.made_otherwise = []
        self._used = None
        self.refused = None

    def settle(self) -> list[DrawMadeOtherwise]:
        """In replay matching draws, once the cycle's update is over: its draws made
        otherwise, the recorded draws left unused among them."""
        used = self._used
        if used is None and len(self.drawn) >= len(self.recorded):  # drew as recorded
            return self.made_otherwise
        start = len(self.drawn) if used is None else 0
        for index in range(start, len(self.recorded)):
            if used is None or not used[index]:
                draw = self.recorded[index]
                name = actor_name(self._recorded_now, draw.actor)
                self.made_otherwise.append(DrawMadeOtherwise(name, _request(draw), None))
        return self.made_otherwise

    def _strict(self, kind: DrawKind, params: tuple[Any, ...]) -> Any:
        """The recorded draw, checked against the request: any difference is refused."""
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
        if not _asks(draw, name, params):
            asked = Draw(actor, name, None, params)
            recorded = _request(draw)
            self._fail(f"called {asked.call()} where {recorded} was recorded", actor, asked=asked)
        if self._owner_of is not None and draw.actor != actor:
            self._check_actor(draw, actor, kind, params)
        self.drawn.append(Draw(actor, name, draw.value, params))
        return draw.value

    def _matched(self, kind: DrawKind, params: tuple[Any, ...]) -> Any:
        """A draw in replay matching draws: the recorded one while the cycle follows
        the recording, else the behavior's match (:meth:`match_draws`)."""
        name = kind._value_
        actor = self._actor
        if self._used is None:
            index = len(self.drawn)
            if index < len(self.recorded):
                draw = self.recorded[index]
                if _asks(draw, name, params) and self._owner(draw.actor) == actor:
                    self.drawn.append(Draw(actor, name, draw.value, params))
                    return draw.value
            self._follow_no_more()
        assert self._used is not None
        match = self._match(actor, name)
        behavior = actor_name(self._names_now, actor)
        if match is None:
            value = self._fresh_value(name, params, None, behavior, actor)
            asked = Draw(actor, name, value, params)
            self.made_otherwise.append(DrawMadeOtherwise(behavior, None, asked.call()))
        else:
            self._used[match] = True
            draw = self.recorded[match]
            if _asks(draw, name, params):
                value = draw.value  # as recorded, in another place
                asked = Draw(actor, name, value, params)
            else:
                quantile = None if name in ARRAY_KINDS else _quantile(draw)
                if quantile is None:
                    value = self._fresh_value(name, params, draw, behavior, actor)
                else:
                    value = scalar_value(name, params, quantile)
                asked = Draw(actor, name, value, params)
                self.made_otherwise.append(
                    DrawMadeOtherwise(behavior, _request(draw), asked.call())
                )
        self.drawn.append(asked)
        return value

    def _owner(self, actor: int) -> int | None:
        """The behavior a recorded actor is now, by its index (None: one the system no
        longer has)."""
        return actor if self._owner_of is None else self._owner_of.get(actor)

    def _follow_no_more(self) -> None:
        """The cycle's draws no longer follow the recording: from here on each is
        matched with its behavior's recorded draws, those drawn so far taken."""
        taken = min(len(self.drawn), len(self.recorded))
        self._used = [True] * taken + [False] * (len(self.recorded) - taken)
        self._owners = [self._owner(draw.actor) for draw in self.recorded]

    def _match(self, actor: int, name: str) -> int | None:
        """The behavior's first recorded draw left of the kind asked for; for a scalar
        with none, its first left of another kind whose quantile is known (re-mapped)."""
        assert self._used is not None
        left = [
            index
            for index, owner in enumerate(self._owners)
            if owner == actor and not self._used[index]
        ]
        same = next((index for index in left if self.recorded[index].kind == name), None)
        if same is not None or name not in SCALAR_VALUES:
            return same
        return next((index for index in left if _quantile(self.recorded[index]) is not None), None)

    def _fresh_value(
        self, name: str, params: tuple[Any, ...], draw: Draw | None, behavior: str, actor: int
    ) -> Any:
        """The value of a request at a fresh quantile, keyed by its place; an array's at
        the quantiles of the recorded ``draw`` where it has one."""
        cycle = self._context.cycle if self._context is not None else -1
        place = Place(cycle, behavior, [draw.actor for draw in self.drawn].count(actor))
        if name in ARRAY_KINDS:
            old = None
            if draw is not None and draw.params:
                old = (draw.kind, draw.params, unpack_array(draw.value))
            return pack_array(array_value(name, params, old, self._fresh.seed(place)))
        return scalar_value(name, params, self._fresh.quantile(place))

    def _check_actor(self, draw: Draw, actor: int, kind: DrawKind, params: tuple[Any, ...]) -> None:
        """Refuse a draw the recording credits to another behavior (by its name now)."""
        expected = self._owner(draw.actor)
        if expected is not None and expected != actor:
            who = "the system" if draw.actor < 0 else self._recorded_names[draw.actor]
            asked = Draw(actor, kind.value, None, params)
            self._fail(
                f"called {asked.call()}, which {who} drew in the recording", actor, asked=asked
            )

    def _fail(
        self, problem: str, actor: int, *, overdrawn: bool = False, asked: Draw | None = None
    ) -> None:
        """Refuse a draw: raise (and remember) it; ``asked`` is kept among those drawn,
        with no value, so reports show what was asked for."""
        if asked is not None:
            self.drawn.append(asked)
        self.refused = RefusedDraw(problem, actor, overdrawn=overdrawn)
        raise self.refused

    def _scalar(self, kind: DrawKind, a: float, b: float, params: tuple[Any, ...]) -> Any:
        value = self._matched(kind, params) if self.matching else self._strict(kind, params)
        if kind is DrawKind.CHOICE and not 0 <= value < b:
            self._fail(
                f"recorded choice index {value} is out of range for {int(b)} items", self._actor
            )
        return value

    def _array(self, kind: DrawKind, a: float, b: float, shape: tuple[int, ...]) -> Any:
        need_numpy()  # before a fresh draw of replay matching draws, too
        params = (a, b, list(shape))
        draw = self._matched if self.matching else self._strict
        array = unpack_array(draw(kind, params))
        if array.shape != shape:
            self._fail(
                f"drew {kind.value} of shape {shape} where {array.shape} was recorded", self._actor
            )
        return array


def _asks(draw: Draw, kind: str, params: tuple[Any, ...]) -> bool:
    """Whether a recorded draw is what is asked for: its kind, and its parameters where
    it recorded them (format 1 recorded none)."""
    return draw.kind == kind and (not draw.params or same_params(draw.params, params))


def _request(draw: Draw) -> str:
    """A recorded draw's request as code; the kind alone where format 1 recorded none."""
    return draw.call() if draw.params else draw.kind


def _quantile(draw: Draw) -> Quantile | None:
    """The quantile of a recorded scalar draw, where it can be known."""
    return scalar_quantile(draw.kind, draw.value, draw.params)
