"""Whether a failure repeats: a failed DTC replayed once more, of a fresh system in the
same process, must fail the same way, else its behaviors are not deterministic."""

from __future__ import annotations

from beatlog.replaying.verdict import Divergence

__all__ = ["repeat_note"]


def repeat_note(first: Divergence, again: Divergence | None, audit: str) -> tuple[str, ...]:
    """The note on a failure that a second replay, of a fresh system in this process,
    does not repeat (``again`` is its first divergence): where the first divergence
    moves between two runs of unchanged code, the behaviors depend on something besides
    their log (the global ``random``, the wall clock, state kept between replays), which
    the audit (the command ``audit``) names."""
    if again is not None and _same(first, again):
        return ()
    if again is None:
        how = f"fails at cycle {first.cycle} in one run and passes in the next"
    elif again.cycle != first.cycle:
        how = f"fails at a different cycle each run ({first.cycle}, then {again.cycle})"
    else:
        how = f"fails otherwise each run at cycle {first.cycle}"
    return (
        f"{how} on unchanged code: the behaviors are not deterministic; run "
        f"`{audit}` to find the call",
    )


def _same(first: Divergence, again: Divergence) -> bool:
    """Whether two divergences are the same: cycle, kind, and what replay did there
    (compared as text, so that a NaN equals itself)."""

    def seen(divergence: Divergence) -> tuple[object, ...]:
        done = (divergence.actual, divergence.actual_outputs, divergence.random_drawn)
        return divergence.cycle, divergence.kind, repr(done)

    return seen(first) == seen(again)
