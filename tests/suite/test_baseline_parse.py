"""Reading a baseline's lines: the common lines read at once read as any line does."""

from __future__ import annotations

import pytest

from beatlog.suite.baseline_parse import ParsedLines, parse_line

_LINES = [
    '      33     1.022  output "happiness" = 49',
    '      66     2.010  output "happiness" as recorded',
    '     114     3.450  output "turn" = 0.5438990161239847  ',
    '       7     0.210  output "speed" absent',
    '       7     0.210  output "leds" = [1, 2, {"a": null}]',
    '       7     0.210  output "image" = msgpack:93010203',
    '       7     0.210  output "odd.name-2" = "text"',
    "      64     1.950  robot_state digests 2 1b8e16e08f698ba7 Wu4H",
    "      64     1.950  robot_state digests 3 1b8e16e08f698ba7 Wu..4H  ",
]


@pytest.mark.parametrize("line", _LINES)
def test_a_common_line_reads_as_any_line_does(line: str) -> None:
    found = ParsedLines()

    found.add(line, 5)

    assert [*found.outputs, *found.blocks] == [parse_line(line, 5)]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ('       7     0.210  output "speed" = ', "Expecting value"),
        ('       7     0.210  output "speed"  absent', "expected '=' at column"),
        ('       7     0.210  output "speed" = 1 2', "unexpected ' 2' after the value"),
        ("      64     1.950  robot_state digests 3 1b8e16e08f698ba7 Wu4H", "expected 6 char"),
    ],
)
def test_a_common_line_that_does_not_read_fails_as_any_line_does(line: str, problem: str) -> None:
    with pytest.raises(ValueError, match=problem) as general:
        parse_line(line, 5)
    with pytest.raises(ValueError, match=problem) as common:
        ParsedLines().add(line, 5)

    assert str(common.value) == str(general.value)
