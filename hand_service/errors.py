"""Errors a user can fix. The CLI prints them as one line and exits with status 2."""

from __future__ import annotations


class UserError(Exception):
    """Bad input (a file, a flag, a value): the message says what and where."""


def where(path: object, line: int | None = None, column: str | None = None) -> str:
    """`file:line: column 'x'` prefix for messages about a place in a file."""
    text = str(path)
    if line is not None:
        text += f":{line}"
    if column is not None:
        text += f": column '{column}'"
    return text
