"""Text files as the readers take them, and values shown in one-line messages.

Every reader of a file a person writes (profiles, models, recordings, trajectories)
decodes it here: UTF-8, with or without a byte-order mark, any line ends; bytes that are
not text are a UserError naming the line, never a UnicodeDecodeError.
"""

from __future__ import annotations

import codecs
from pathlib import Path

from hand_service.errors import UserError, where


def show(value: object, limit: int = 40) -> str:
    """repr(value) for a one-line message: never longer than `limit` characters."""
    try:
        text = repr(value)
    except (RecursionError, ValueError):  # a list that holds itself, an integer of 5000 digits
        text = f"<a {type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def printable(text: str) -> str:
    """Text as it is if it prints on one line, else its shortened repr."""
    return text if text.isprintable() else show(text, 200)


def cell_text(text: str, limit: int = 60) -> str:
    """A cell of a file for a one-line message: escaped (a quoted CSV cell may hold line
    ends) and shortened."""
    if not text.isprintable():
        text = repr(text)[1:-1]
    return text if len(text) <= limit else text[: limit - 3] + "..."


_BOMS = ((codecs.BOM_UTF8, "utf-8-sig"), (codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
         (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"))


def decode_text(data: bytes, path: str | Path) -> str:
    """A text file's bytes as text: UTF-8 (or UTF-16/32 with a byte-order mark; a UTF-8 mark
    is dropped), line ends CRLF and CR made LF. Other bytes are a UserError naming the line."""
    codec = next((name for bom, name in _BOMS if data.startswith(bom)), "utf-8")
    try:
        text = data.decode(codec)
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        name = "UTF-8" if codec.startswith("utf-8") else codec.upper()
        raise UserError(f"{where(path, line)}: not {name} text (byte "
                        f"0x{data[exc.start]:02x} at offset {exc.start}): save the file as UTF-8") from None
    if "\0" in text:  # valid UTF-8, and never in a text file: UTF-16 without its mark, most likely
        line = text[: text.index("\0")].count("\n") + 1
        raise UserError(f"{where(path, line)}: a NUL byte in the text (UTF-16 without a byte-order "
                        "mark?): save the file as UTF-8")
    return text.replace("\r\n", "\n").replace("\r", "\n")


def read_text(path: str | Path) -> str:
    """A text file (decode_text); an unreadable one is a UserError."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except ValueError as exc:  # a NUL in the path
        raise UserError(f"{show(str(path))}: not a usable path: {exc}") from None
    return decode_text(data, path)


def lookup(path: Path) -> str | None:
    """What is at `path`: "file" (a regular file), "other" (a directory, a FIFO, a device:
    reading one may never end) or None (nothing). A name the system cannot look up at all
    (too long, a NUL in it) is a UserError, not an OSError from Path.exists."""
    try:
        if not path.exists():
            return None
        return "file" if path.is_file() else "other"
    except OSError as exc:
        raise UserError(f"{show(str(path))}: cannot look it up: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise UserError(f"{show(str(path))}: not a usable path: {exc}") from None

