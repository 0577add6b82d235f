"""MkDocs hooks: the pages that are generated from the code at build time, so that they
cannot drift from it: the CLI reference (every ``--help`` page the parser prints) and the
glossary (:mod:`beatlog.report.glossary`, the entries ``beatlog help TERM`` prints)."""

from __future__ import annotations

import contextlib
import io
import os
from typing import Any

from beatlog.cli.commands import COMMANDS
from beatlog.cli.main import build_parser
from beatlog.report import glossary

WIDTH = "88"
"""The columns the help pages are wrapped to."""


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    """Fill a page's ``<!-- generated: cli -->`` or ``<!-- generated: glossary -->``."""
    markdown = markdown.replace("<!-- generated: cli -->", cli_reference())
    return markdown.replace("<!-- generated: glossary -->", glossary_page())


def help_page(*argv: str) -> str:
    """What ``beatlog ARGV --help`` prints."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = WIDTH
    page = io.StringIO()
    try:
        with contextlib.redirect_stdout(page), contextlib.suppress(SystemExit):
            build_parser().parse_args([*argv, "--help"])
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous
    return page.getvalue()


def cli_reference() -> str:
    """``beatlog --help``, then each subcommand's page under its own heading."""
    sections = [f"## beatlog\n\n```text\n{help_page()}```\n"]
    for name, command in COMMANDS.items():
        what = command.help[0].upper() + command.help[1:]
        sections.append(f"## beatlog {name}\n\n{what}.\n\n```text\n{help_page(name)}```\n")
    return "\n".join(sections)


def glossary_page() -> str:
    """Every entry of the glossary, in alphabetical order, each under its own heading."""
    parts = []
    for entry in sorted(glossary.entries(), key=lambda entry: entry.term.casefold()):
        parts.append(f"### {entry.term}\n\n{entry.meaning}\n")
        if entry.aliases:
            printed = ", ".join(f"`{alias}`" for alias in entry.aliases)
            parts.append(f"Also printed as: {printed}.\n")
        if entry.see:
            parts.append(f"More: [{entry.see.removesuffix('.md')}]({entry.see}).\n")
    return "\n".join(parts)
