"""Reading a baseline's lines: the common lines read at once read as any line does."""

from __future__ import annotations

import pytest

from beatlog.baseline.read import ParsedLines, line_feeds, parse_line
from beatlog.replay.draws import ApprovedDraws

_COMMON = [
    '      33     1.022  output "happiness" = 49',
    '      66     2.010  output "happiness" as recorded',
    '     114     3.450  output "turn" = 0.5438990161239847',
    '     114     3.450  output "odd name ü" = -0.0',
    '     115     3.480  output "" = NaN',
    '     115     3.480  output "speed" = -Infinity',
    '     115     3.480  output "speed" = 1e5',
    '     116     3.510  output "mode" = "a, b -> c"',
    '     116     3.510  output "flag" = true',
    '     116     3.510  output "none" = null',
    '     117     3.540  output "speed" absent',
    "     120     3.600  robot_state digests 2 1b8e16e08f698ba7 Wu4H",
    "     123     3.690  robot_state digests 3 1b8e16e08f698ba7 Wu..4H",
    '     130 999999.999  "avoid": "idle" -> "turning"',
    '     130     3.900  "count": -3 -> 0',
    '     130     3.900  "": true -> null',
    '     130    03.900  "avoid": false -> 1',
    '     130     3.900  "big": 123456789012345678901234567890 -> -0',
    "     131     3.930  no state changes",
]
"""Lines of every common shape, each read at once by ``read_common``."""
_OTHERS = [
    "# a comment",
    "   ",
    "      40     1.200  open loop",
    '      41     1.230  output "image" = msgpack:93010203',
    '      41     1.230  output "escaped\\"" = [1, 2, {"a": null}]',
    '      41     1.230  output "speed" = 0.5  ',
    '      42     1.260  "escaped\\"": "a" -> "b"',
    '      43     1.290  robot_state otherwise in 43..43 (1 cycle): ["a"], first {"a": 1}',
    '     120 1000000.000  output "speed" = 1',
]
"""Lines near the common shapes that ``read_common`` leaves to ``add``."""
_ODD = [
    '    0120     3.600  output "speed" = 1',
    "      64     1.950  robot_state digests 03 1b8e16e08f698ba7 Wu4H12",
    '    0064     1.950  "avoid": 0 -> 1',
]
"""Lines of a common shape, yet not as it is written: the file is read line by line."""


def _read(lines: list[str]) -> tuple[ParsedLines, list[int]]:
    """The lines read as a baseline's are, and the numbers of those left to ``add``."""
    found = ParsedLines()
    others = []
    for number, line in found.read_common("\n".join(lines), start=1):
        others.append(number)
        if line.strip() and not line.startswith("#"):
            found.add(line)
    return found, others


def _read_one_by_one(lines: list[str]) -> ParsedLines:
    found = ParsedLines()
    for line in lines:
        if line.strip() and not line.startswith("#"):
            found.add(line)
    return found


def test_common_lines_read_at_once_read_as_each_line_alone_bit_for_bit() -> None:
    lines = [*_OTHERS[:3], *_COMMON[:5], *_OTHERS[3:], "", *_COMMON[5:]]

    found, others = _read(lines)

    assert repr(found) == repr(_read_one_by_one(lines))
    assert others == [1, 2, 3, *range(9, 9 + len(_OTHERS) - 3)]


@pytest.mark.parametrize("line", _COMMON)
def test_each_common_line_reads_as_parse_line_reads_it(line: str) -> None:
    found, others = _read([line])

    assert others == []
    parsed = parse_line(line)
    kept = [*found.outputs, *found.blocks, *found.changes, *found.quiet]
    assert repr(kept) == repr([parsed[:2] if line.endswith("no state changes") else parsed])


@pytest.mark.parametrize("line", _OTHERS)
def test_a_line_near_the_common_shapes_is_left_to_add(line: str) -> None:
    assert _read([_COMMON[0], line])[1] == [2]


@pytest.mark.parametrize("line", _ODD)
def test_a_file_with_a_line_of_a_common_shape_written_otherwise_is_read_line_by_line(
    line: str,
) -> None:
    lines = [_COMMON[0], line, _COMMON[1]]

    found, others = _read(lines)

    assert (repr(found), others) == (repr(_read_one_by_one(lines)), [1, 2, 3])


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ('       7     0.210  output "speed" = 1.2.3', "unexpected '.3' after the value"),
        ('       7     0.210  output "speed" = 012', "unexpected '12' after the value"),
        ('       7     0.210  output "speed" = nope', "Expecting value"),
        ('       7     0.210  "avoid": 1 -> truth', "Expecting value"),
        ('       7     0.210  "avoid": 0.5 -> 1', "a state must be a string"),
        ("      64     1.950  robot_state digests 3 1b8e16e08f698ba7 Wu4H", "expected 6 char"),
        ("      64     1.950  robot_state digests 2 1B8E16E08F698BA7 Wu4H", "expected 'robot_st"),
    ],
)
def test_a_line_that_does_not_read_fails_as_parse_line_fails(line: str, problem: str) -> None:
    with pytest.raises(ValueError, match=problem) as general:
        parse_line(line)
    with pytest.raises(ValueError, match=problem) as read:
        _read([_COMMON[0], line, _COMMON[1]])

    assert str(read.value) == str(general.value)


def test_robot_times_read_at_once_to_the_nanosecond_as_each_alone() -> None:
    lines = [
        f"{cycle:>8} {millis // 1000:>5}.{millis % 1000:03}  no state changes"
        for cycle, millis in enumerate(range(0, 10**9, 49_999))
    ]

    found, others = _read(lines)

    assert (found.quiet, others) == (_read_one_by_one(lines).quiet, [])


@pytest.mark.parametrize("first", [0, 1])
def test_robot_times_under_a_second_read_at_once_as_each_alone(first: int) -> None:
    lines = [
        f"{cycle:>8} {millis // 1000:>5}.{millis % 1000:03}  no state changes"
        for cycle, millis in enumerate([*range(first, 1000), 1000, 1001, 10_000, 999_999_999])
    ]

    found, others = _read(lines)

    assert (found.quiet, others) == (_read_one_by_one(lines).quiet, [])


@pytest.mark.parametrize(
    ("line", "rule"),
    [
        (
            'draws "wander": uniform(0.8, 1.6) -> uniform(0.7, 1.5) in cycles 12 97 240',
            ApprovedDraws("wander", "uniform(0.8, 1.6)", "uniform(0.7, 1.5)", (12, 97, 240)),
        ),
        (
            'draws "a -> b": - -> x in cycles y -> z in cycles 0 007 \u0661\u0662',
            ApprovedDraws("a -> b", None, "x in cycles y -> z", (0, 7, 12)),
        ),
        (
            'draws "e\\u00e9": random() -> - in cycles 5',
            ApprovedDraws("eé", "random()", None, (5,)),
        ),
        (
            'draws "w": a -> b in cycles 1 in cycles 2',
            ApprovedDraws("w", "a", "b in cycles 1", (2,)),
        ),
        ('draws "a\\"b": x -> y in cycles 1', ApprovedDraws('a"b', "x", "y", (1,))),
        ('draws "a\\\\": "x" -> y in cycles 1', ApprovedDraws("a\\", '"x"', "y", (1,))),
    ],
)
def test_a_draws_line_reads_whole(line: str, rule: ApprovedDraws) -> None:
    found = ParsedLines()

    found.add(line)

    assert found.draws == [rule]


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ('draws "w": a -> b in cycles 1  2', 'expected \'draws "behavior": RECORDED'),
        ('draws "w": a -> b in cycles 1 2 ', 'expected \'draws "behavior": RECORDED'),
        ('draws "w": a -> b in cycles  1', 'expected \'draws "behavior": RECORDED'),
        ('draws "w": a -> a in cycles 1', "a draw of a as recorded is no difference"),
        ('draws "a\\\\"b": x -> y in cycles 1', 'expected \'draws "behavior": RECORDED'),
        ('draws "w\\x": a -> b in cycles 1', "Invalid \\\\escape: line 1 column 3"),
    ],
)
def test_a_draws_line_that_does_not_read_says_why(line: str, problem: str) -> None:
    with pytest.raises(ValueError, match=problem):
        ParsedLines().add(line)


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r", "\x0c", "\x1e", "\x85", "\u2028"])
@pytest.mark.parametrize("ended", [True, False])
def test_a_block_reads_as_the_lines_splitlines_breaks_it_into(end: str, ended: bool) -> None:
    lines = ["# header", _COMMON[0], "", *_OTHERS[2:4], _COMMON[11], _COMMON[-1]]
    text = end.join(lines) + (end if ended else "")

    fed, count = line_feeds(text)
    first, _, rest = fed.partition("\n")
    found, others = _read(rest.removesuffix("\n").split("\n"))

    assert count == len(lines)
    assert (first, repr(found)) == ("# header", repr(_read_one_by_one(text.splitlines()[1:])))
    assert others == [3, 4]
