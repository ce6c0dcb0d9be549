"""A trajectory's parse error as the control API tells it: where (the file, the line, a
column the format knows) and what was wrong, in words of its own, never a word of the
file's text. The reader's own messages quote a bad cell or header (useful at a
terminal); a daemon must not hand a file's contents to a client."""

from __future__ import annotations

import re

from hand_service.config.profile import Profile
from hand_service.errors import where
from hand_service.service.trajectory_csv import MAX_ROWS, MAX_TICKS, QUANTITIES

# (a phrase of the reader's message, what the client is told); the first that matches
REASONS: tuple[tuple[str, str], ...] = (
    ("unknown column", "unknown column: expected t, angle_ref_deg_<finger> or force_ref_n_<finger> "
                       "for a finger of the profile"),
    ("missing required column 't'", "missing required column 't'"),
    ("no angle_ref_deg_<finger> or force_ref_n_<finger> column",
     "no angle_ref_deg_<finger> or force_ref_n_<finger> column"),
    ("fields where the header has", "the row does not have as many fields as the header"),
    ("does not increase", "t does not increase"),
    ("where a finite number is required", "not a finite number"),
    ("not a number", "not a number"),
    ("has both an angle and a force reference", "a finger has both an angle and a force reference in "
                                                "one row; give one"),
    ("ticks; the limit is", f"longer than the limit of {MAX_TICKS} ticks"),
    ("rows; the limit is", f"more than the limit of {MAX_ROWS} rows"),
    ("not UTF-8 text", "not UTF-8 text: save the file as UTF-8"),
    ("not a CSV text file", "not a CSV text file"),
    ("needs a header and at least two rows", "a trajectory needs a header and at least two rows"),
)
_RANGE = re.compile(r"is outside the profile's target range (\[[-+0-9.e]+, [-+0-9.e]+\] (?:deg|N))$")
_STRERROR = re.compile(r"[A-Za-z ,'-]{1,80}")


def known_columns(profile: Profile) -> list[str]:
    return ["t", *(f"{q}_{name}" for q in QUANTITIES for name in profile.finger_names)]


def trajectory_error(message: str, path: str, profile: Profile) -> str:
    """The client's version of the reader's `message` about the file at `path`: built only
    from `path`, the line number, a column name the format defines and fixed words."""
    rest = message[len(path):] if message.startswith(path) else ""
    if rest.startswith(" is not a regular file"):
        return f"{path} is not a regular file (a FIFO, device or directory is never read)"
    if rest.startswith(": cannot read: "):
        why = rest[len(": cannot read: "):]
        return f"{path}: cannot read: {why if _STRERROR.fullmatch(why) else 'the system refused'}"
    line_match = re.match(r":(\d{1,12})(?::|$)", rest)
    line = int(line_match.group(1)) if line_match else None
    column = None
    if line is not None:
        column = next((name for name in known_columns(profile)
                       if rest.startswith(f":{line}: column '{name}': ")), None)
    range_match = _RANGE.search(message)
    if range_match:
        reason = f"outside the profile's target range {range_match.group(1)}"
    else:
        reason = next((said for phrase, said in REASONS if phrase in rest),
                      "not a valid trajectory (docs/trajectory.md)")
    return f"{where(path, line, column)}: {reason}"
