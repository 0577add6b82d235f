"""Checks on what a command or a report printed: a test asserts that a whole line is
among its lines, so a fragment of another line ("complete" in "incomplete") cannot pass."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

__all__ = ["frames", "suite_names", "svg_texts", "table_row", "whole_lines"]


BORDERS = " \t│╭╮╰╯─"
"""What frames a line of a console report: its indent and a panel's or a table's edges."""


def whole_lines(text: str) -> list[str]:
    """The lines of ``text``, each without what frames it (its indent, a panel's edges)."""
    return [line.strip(BORDERS) for line in text.splitlines()]


def table_row(text: str, first: str) -> list[str]:
    """The cells of the row of a console table whose first cell is ``first`` (empty where
    no row is), e.g. ``["dock", "passed", "300", "9.0 s", "0.01 s"]``."""
    for line in whole_lines(text):
        cells = [cell.strip() for cell in line.split("│")]
        if cells[0] == first:
            return cells
    return []


def suite_names(text: str) -> list[str]:
    """The DTCs listed, in order, in the table that ``beatlog test`` prints under "DTC suite"
    (empty where it printed none)."""
    lines = whole_lines(text)
    if "DTC suite" not in lines:
        return []
    names = []
    for line in lines[lines.index("DTC suite") + 1 :]:
        if line.startswith("└"):
            break
        first = line.split("│")[0].strip()
        if "│" in line and first:
            names.append(first)
    return names


_FRAME = re.compile(r'\s*File "(?P<file>[^"]+)", line \d+, in (?P<function>\S+)')


def frames(traceback: str) -> list[tuple[str, str]]:
    """The frames of a printed traceback, outermost first: each one's file and function
    (their line numbers left out, so that editing a file does not break a test)."""
    return [
        (found["file"], found["function"])
        for found in map(_FRAME.fullmatch, traceback.splitlines())
        if found is not None
    ]


def svg_texts(svg: str) -> list[str]:
    """The texts an SVG chart draws, in order, as a reader sees them (entities decoded)."""
    return [text.text or "" for text in ET.fromstring(svg).iter("{http://www.w3.org/2000/svg}text")]
