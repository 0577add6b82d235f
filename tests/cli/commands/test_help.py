"""``beatlog help [COMMAND | TERM]``: the page ``--help`` prints, or what a word means."""

from __future__ import annotations

import pytest

from beatlog.cli.main import main
from tests.commands import Beatlog, assert_error

pytestmark = pytest.mark.usefixtures("wide_plain_console")


@pytest.mark.parametrize("topic", [[], ["test"], ["replay"]])
def test_help_prints_the_page_help_does(
    topic: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main([*topic, "--help"])
    page = capsys.readouterr().out

    with pytest.raises(SystemExit) as helped:
        main(["help", *topic])

    assert (exited.value.code, helped.value.code) == (0, 0)
    assert capsys.readouterr().out == page


@pytest.mark.parametrize(
    ("command", "said"),
    [
        ("test", "each task carries the logs and baselines it reads"),  # --dask, as the guide
        ("test", "the workers need the system's package installed"),
        ("import-bag", "or a ROS 1 .bag"),
    ],
)
def test_a_help_page_says_what_its_guide_says(
    command: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["help", command])

    assert said in " ".join(capsys.readouterr().out.split())


def test_help_of_a_word_prints_its_glossary_entry(beatlog: Beatlog) -> None:
    run = beatlog("help", "open-loop")

    assert run.code == 0
    lines = run.out.splitlines()
    assert lines[0] == "open loop"
    assert lines[1].startswith("  From the first cycle where an approved change")
    assert lines[-2:] == [
        "  also printed as: open loop since cycle, worth re-recording when convenient",
        "  more: docs/how-to/intended-changes.md",
    ]


@pytest.mark.parametrize("words", [["RS_t"], ["robot", "state"], ["Robot-State"]])
def test_help_finds_a_word_by_any_spelling(words: list[str], beatlog: Beatlog) -> None:
    run = beatlog("help", *words)

    assert (run.code, run.out.splitlines()[0]) == (0, "robot state")


def test_help_lists_the_whole_glossary(beatlog: Beatlog) -> None:
    run = beatlog("help", "--glossary")

    terms = [line for line in run.out.splitlines() if line and not line.startswith(" ")]
    assert run.code == 0
    assert {"open loop", "vouch", "extra random draw", "pending", "arbiter"} <= set(terms)


def test_help_of_an_unknown_word_is_one_line_with_the_nearest(beatlog: Beatlog) -> None:
    run = beatlog("help", "vouhc")

    assert_error(
        run,
        "'vouhc' is neither a command nor a word of the glossary; did you mean "
        "'vouch'? (beatlog help --glossary lists them)",
    )
