"""The system replay builds: by default the one the log's header records, and built
after the header is read, its factory handed a source that serves the recorded set-up
draws (:mod:`beatlog.model.setup`).

The set-up draws are checked as a cycle's draws are: a draw too many, too few, of
another kind or with other parameters is a divergence at set-up
(:class:`SetupDrawError`), before cycle 0. In replay matching draws too: an approved baseline
holds no set-up draws, so a change to them needs a new recording.
"""

from __future__ import annotations

from pathlib import Path

from beatlog.errors import BeatlogError, CorruptLogError, SystemLoadError
from beatlog.log.format import SessionHeader
from beatlog.log.reader import SessionLogReader
from beatlog.model.behavior import System
from beatlog.model.draws import recorded_draw_problem
from beatlog.model.setup import SystemFactory, build_system
from beatlog.project.config import vouched_system
from beatlog.project.usercode import load_system
from beatlog.replay.random import RefusedDraw, ReplayRandom

__all__ = ["SetupDrawError", "built_for_replay", "recorded_system"]


class SetupDrawError(BeatlogError):
    """The system's factory drew otherwise than recorded while it built the system.

    :func:`beatlog.replay` turns it into a divergence of kind
    :attr:`~beatlog.replay.verdict.DivergenceKind.SETUP`; where nothing does, it is
    one line naming the log.
    """

    def __init__(self, path: Path, problem: str, *, recorded_system: str = "") -> None:
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem
        self.recorded_system = recorded_system
        """The ``module:factory`` the log's header records, for a reproduce command."""


def built_for_replay(
    system: System | SystemFactory | str,
    header: SessionHeader,
    path: Path,
    random: ReplayRandom,
) -> System:
    """The system to replay the log of ``header`` against: ``system`` itself, or what the
    factory ``system`` (or the ``module:factory`` reference ``system``) builds from
    ``random`` serving the recorded set-up draws.

    :raises beatlog.errors.CorruptLogError: a set-up draw is one no recording makes.
    :raises beatlog.errors.SystemLoadError: the log holds set-up draws and ``system`` is
        a system already built, which replay cannot hand them.
    :raises SetupDrawError: the factory drew otherwise than recorded.
    """
    recorded = header.drawn_at_setup()
    for number, draw in enumerate(recorded, 1):
        damage = recorded_draw_problem(draw, len(header.behaviors))
        if damage is not None:
            raise CorruptLogError(path, f"damaged set-up draw {number}: {damage}")
    if not isinstance(system, str) and isinstance(system, System):
        if recorded:
            raise SystemLoadError(
                f"{path}: its system drew {len(recorded)} random "
                f"number{'' if len(recorded) == 1 else 's'} at set-up: replay it against "
                "the system's factory (module:factory), which is handed them, not a system "
                "already built"
            )
        return system
    random.load(recorded)
    problem: str | None
    try:
        built = (
            load_system(system, random=random)
            if isinstance(system, str)
            else build_system(system, random)
        )
    except RefusedDraw as refused:
        problem = refused.problem
    else:
        problem = None if random.refused is None else random.refused.problem  # swallowed
    drawn = len(random.drawn)
    if problem is None and drawn < len(recorded):
        problem = (
            f"drew {drawn} of the {len(recorded)} random numbers recorded; the first not "
            f"drawn: {recorded[drawn].call()}"
        )
    if problem is not None:
        raise SetupDrawError(
            path, f"at set-up, the system's factory {problem}", recorded_system=header.system
        )
    return built


def recorded_system(log: str | Path, *, project: Path | None = None) -> str:
    """The system reference the log's header records (``beatlog record --system-ref``),
    once the project vouches for it: bytes from a log never choose code on their own.

    ``project`` is a folder of the project whose ``[tool.beatlog] systems`` must list
    the reference (the working directory by default; a spec's folder for a spec), see
    :func:`beatlog.project.config.vouched_system`.

    :raises beatlog.errors.SystemLoadError: the log records none, or one the project
        does not list.
    """
    with SessionLogReader(log) as reader:
        reference = reader.header.system
    return vouched_system(log, reference, project=Path.cwd() if project is None else project)
