"""``beatlog help [COMMAND]``: the page ``--help`` prints."""

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


def test_help_of_an_unknown_command_is_one_line(beatlog: Beatlog) -> None:
    run = beatlog("help", "nope")

    assert_error(
        run,
        "argument COMMAND: invalid choice: 'nope' (choose from 'approve', 'demo', 'export', "
        "'help', 'import-bag', 'plot', 'record', 'replay', 'review', 'show', 'test') "
        "(see 'beatlog help --help')",
    )
