"""The ``beatlog`` command line: a ``--help`` page for every subcommand of the table,
with what it does, its defaults and the exit codes."""

from __future__ import annotations

import re

import pytest

from beatlog.cli.commands import COMMANDS
from beatlog.cli.main import EXIT_CODES, main

pytestmark = pytest.mark.usefixtures("wide_plain_console")

SUBCOMMANDS = [
    "record",
    "replay",
    "test",
    "shrink",
    "review",
    "approve",
    "upgrade-baselines",
    "show",
    "plot",
    "export",
    "import-bag",
    "help",
    "demo",
]
"""Every subcommand, in the order ``beatlog --help`` lists them."""


def help_page(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exited:
        main([command, "--help"])
    assert exited.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_help_page_describes_the_command_its_arguments_and_exit_codes(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    page = help_page(command, capsys)
    description = page.split("\n\n")[1]
    positionals = page.partition("positional arguments:\n")[2].partition("\n\n")[0]

    assert description.endswith(".")
    assert all(len(line.split()) > 1 for line in positionals.splitlines())
    assert page.rstrip().endswith(EXIT_CODES.rstrip())
    codes = page.partition("exit codes:\n")[2].splitlines()
    assert [line.split()[0] for line in codes] == ["0", "1", "2", "5", "130", "143"]


@pytest.mark.parametrize(
    ("command", "default"),
    [
        ("record", "heartbeat period in ms (default: 30.0)"),
        ("record", "(default: 1.0)"),
        ("demo", "(default: beatlog-demo)"),
        ("demo", "(default: 20.0)"),
        ("test", "(default: the current folder)"),
    ],
)
def test_help_pages_show_defaults(
    command: str, default: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert default in " ".join(help_page(command, capsys).split())


def test_test_help_says_what_k_and_repeated_tags_mean(
    capsys: pytest.CaptureFixture[str],
) -> None:
    page = " ".join(help_page("test", capsys).split())

    helps = re.search(r" -k EXPRESSION (.*) --tag TAG (.*) -x, --exitfirst, --fail-fast ", page)
    assert helps is not None, page
    assert helps.groups() == (
        "only DTCs matching this expression, as pytest's -k: words matched against names and "
        "tags, with and, or, not and parentheses (e.g. -k 'touch or pat'); the names are the "
        "DTC's, its spec file's and its folders' below the rootdir",
        "only DTCs with this tag; given more than once, only DTCs with every tag given",
    )


def test_the_top_level_help_ends_with_the_exit_codes(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["--help"])

    assert exited.value.code == 0
    assert capsys.readouterr().out.rstrip().endswith(EXIT_CODES.rstrip())


@pytest.mark.parametrize("command", [name for name in SUBCOMMANDS if name != "test"])
def test_verbose_says_what_it_does_for_the_command_at_hand(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert verbose_help(command, capsys) == (
        "also print the traceback of user code that failed to load"
    )


def test_test_verbose_lists_every_dtc(capsys: pytest.CaptureFixture[str]) -> None:
    assert verbose_help("test", capsys) == (
        "list every DTC in the summary, and print the traceback of user code that failed to load"
    )


def verbose_help(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    """What the help page of ``command`` says ``--verbose`` does, on one line."""
    page = " ".join(help_page(command, capsys).split())
    verbose = re.search(r" -v, --verbose (.*?) (-|exit codes:)", page)
    assert verbose is not None, page
    return verbose[1]


def test_review_help_says_it_asks_about_each_change_and_loss_and_approve_does_not_ask(
    capsys: pytest.CaptureFixture[str],
) -> None:
    review = " ".join(help_page("review", capsys).split())
    approve = " ".join(help_page("approve", capsys).split())

    assert review.startswith(
        "usage: beatlog review [-h] [-v] [paths ...] Show each pending baseline change with "
        "what it loses, and ask whether to accept, reject or skip it (and each loss); "
        "accepting writes the approved baseline."
    )
    assert "Accept every pending baseline of DTC specs without asking, naming each loss" in approve


def test_the_commands_are_those_of_the_table_once_each_in_its_order(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    usage = capsys.readouterr().out

    assert list(COMMANDS) == SUBCOMMANDS
    assert usage.count("{" + ",".join(COMMANDS) + "}") == 2
