"""The glossary: every word the terminal prints has an entry that ``beatlog help`` prints
and the documentation's glossary page shows."""

from __future__ import annotations

from pathlib import Path

from beatlog.replay.verdict import DivergenceKind
from beatlog.report import glossary
from beatlog.report.console import SUMMARY_COLUMNS
from beatlog.suite.runner import Verdict

DOCS = Path(__file__).parents[2] / "docs"

PRINTED = [
    # the closing counts and the verdict labels
    "not run",
    "open loop",
    "worth re-recording when convenient",
    "approved baseline",
    "retried",
    "waiting for storage",
    "errors",
    # the failure panel and a replay's lines
    "first divergence",
    "behavior state changes",
    "random numbers",
    "state changes around it",
    "robot state RS_t",
    "fields read in this cycle",
    "log complete",
    "not read",
    "recorded",
    "replayed",
    "samples",
    "reproduce",
    "checked",
    "allowed empty",
    "note",
    "arbiter",
    "HB_t",
    "RN_t",
    "BS_t",
    "behavior states after the update",
    "does not hold",
    "invariant violation",
    # beatlog show
    "behaviors",
    "id",
    "recording",
    "format",
    "status",
    "complete",
    "truncated",
    "index damaged, data intact",
    "system",
    "duration",
    "heartbeat",
    "overruns",
    "robot state",
    "not logged",
    "catalogue",
    "robot",
    "software",
    "p99",
    "recording error",
    # re-baselining: test --update, review, approve, baseline files
    "pending",
    "nothing pending",
    "not updated",
    "removed stale",
    "left pending",
    "accepted",
    "rejected",
    "state and output changes",
    "orphaned baseline",
    "CI is set",
    "expected departures from the recording",
    "no state changes",
    "as recorded",
    "absent",
    "draws made otherwise",
    "robot_state digests",
    "rebuilt otherwise",
    "re-mapped",
    "new",
    "left unused",
    "closed loop, as recorded",
    "state changes lost",
    "moved",
    "output changes",
    "no longer happen",
    "never output any more",
    "no longer made",
    "accept this loss",
    "accepted loss",
    "closed loop for",
    "stale suite",
    "re-record first",
    "nothing pending to approve",
    # fitting a log, trusting its system, coverage, the audit
    "does not fit",
    "vouch",
    "transition coverage",
    "states reached",
    "transitions",
    "unreached",
    "seen before",
    "audit",
    "determinism audit",
    "PYTHONHASHSEED",
    "certified",
    "not certified",
    "fails at a different cycle each run",
    "fails otherwise each run",
    "changes between heartbeats",
    "heartbeat period",
    "looks like another robot's log",
    "unseeded numpy.random.Generator",
    "findings",
    "at set-up",
    # beatlog upgrade-baselines
    "upgraded",
    "older format",
    # beatlog shrink, and a spec's window
    "shrunk",
    "nothing to shrink",
    "replays tried",
    "perturbations",
    "window",
    "before the window",
    "fresh start",
    "replayed before it",
    "not replayed",
    # variants
    "variant",
    "of them variants",
    "written",
    "a failing variant, now a DTC of its own",
]
"""The words the CLI's messages and reports print that no enum or constant lists."""


def test_every_word_the_terminal_prints_has_a_glossary_entry() -> None:
    printed = [
        *(kind.value for kind in DivergenceKind),
        *(verdict.value for verdict in Verdict),
        *SUMMARY_COLUMNS,
        *PRINTED,
    ]

    assert [words for words in printed if glossary.lookup(words) is None] == []


def test_a_word_is_found_in_any_case_with_hyphens_or_underscores_for_spaces() -> None:
    entry = glossary.lookup("open loop")

    assert entry is not None
    assert glossary.lookup("Open-Loop") == glossary.lookup("open_loop") == entry
    assert glossary.lookup("no such word") is None
    assert glossary.near("opn loop")[0] == "open loop"


def test_every_spelling_names_one_entry() -> None:
    spellings = [
        " ".join(name.casefold().replace("-", " ").replace("_", " ").split())
        for entry in glossary.entries()
        for name in (entry.term, *entry.aliases)
    ]

    assert sorted({s for s in spellings if spellings.count(s) > 1}) == []


def test_every_entry_says_something_and_points_to_a_page_that_exists() -> None:
    for entry in glossary.entries():
        assert entry.meaning.endswith((".", ")")), entry.term
        assert entry.see is None or (DOCS / entry.see).is_file(), entry
