"""``-k`` expressions read as pytest reads them: words over the names pytest gives a DTC."""

from __future__ import annotations

import pytest

from beatlog.errors import OptionError
from beatlog.suite.keywords import KeywordExpression

HEAD_PAT = ("head-pat", "touch", "happy")
PUSH_OVER = ("push-over", "falls")


@pytest.mark.parametrize(
    ("expression", "head_pat", "push_over"),
    [
        ("pat", True, False),
        ("PAT", True, False),
        ("touch", True, False),
        ("touch or push", True, True),
        ("touch and not happy", False, False),
        ("not touch", False, True),
        ("(touch or falls) and over", False, True),
        ("not (pat or over)", False, False),
        ("", True, True),
        ("   ", True, True),
    ],
)
def test_a_word_matches_a_substring_of_one_of_the_names(
    expression: str, head_pat: bool, push_over: bool
) -> None:
    parsed = KeywordExpression.parse(expression)

    assert parsed.matches(HEAD_PAT) is head_pat
    assert parsed.matches(PUSH_OVER) is push_over


@pytest.mark.parametrize(
    ("expression", "problem"),
    [
        ("touch or", "ends where a word was expected"),
        ("(touch", "a '(' is not closed"),
        ("touch pat", "unexpected 'pat'"),
        ("and touch", "expected a word, got 'and'"),
        ("touch)", "unexpected ')'"),
        ("dock*", "unexpected character '*'"),
    ],
)
def test_a_malformed_expression_is_one_line_naming_it(expression: str, problem: str) -> None:
    with pytest.raises(OptionError) as raised:
        KeywordExpression.parse(expression)

    assert str(raised.value) == f"-k {expression!r}: {problem}"
