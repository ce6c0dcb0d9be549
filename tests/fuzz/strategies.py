"""Inputs for the fuzz tests: valid documents with mutated values, and raw bytes.

Every text strategy ends in `encoded()`, which may add a UTF-8 byte-order mark, turn the
line ends into CRLF or CR, encode in Latin-1 or UTF-16, flip bytes or cut the file short.
"""

from __future__ import annotations

import copy
import json
import re
from typing import Any

import yaml
from hypothesis import strategies as st

# -- YAML ---------------------------------------------------------------------------------
YAML_VALUES = [
    "!!int 1e3", "!!int 0x", "!!int ''", "!!float abc", "!!float ''", "!!bool maybe", "!!null x",
    "!!binary ###", "!!binary aGVsbG8=", "!!timestamp 2001-13-45", "!!timestamp x", "!!str 5",
    "!!python/object:os.system ''", "!!python/name:os.system", "!!set {a, b}", "!!omap [a: 1]",
    "!!pairs [a: 1]", "!!map [1]", "!!seq {a: 1}", "!mytag 3", "!<tag:yaml.org,2002:int> x",
    "!!merge x", "[sim]", "[]", "{}", "{a: 1}", "[[1, [2, [3]]]]", "{? [a]: 1}", "[1, {b: [2]}]",
    ".nan", ".NaN", ".inf", "-.inf", "+.inf", "1e400", "-1e400", "1e-400", "1e308", "1.8e308",
    "9" * 400, "-" + "9" * 400, "9" * 5000, "0x" + "f" * 400, "0o777", "0b101", "1_000", "1:30",
    "190:20:30", "2001-12-14", "2001-12-14t21:59:43.10-05:00", "~", "null", "true", "no", "on",
    "''", '""', '"\\0"', '"\\uFFFF"', '"\\ud800"', "é", "💥", "\u202e", "&a 1", "*a", "*undefined",
    "&a [*a]", "|\n  text", ">", "- 1", "? a", "<<", ": ", "@", "`", "%YAML", "'open", '"\\x"',
    "1e3", "-0", "0.0", "-1", "0", "1", "2.5", "1000000", "-1000000", "0.000001", "1.0e-3",
    "[" * 400 + "]" * 400, "{a: " * 300 + "1" + "}" * 300, "a: b: c", "\t1", "1 # comment",
    "'x'", "\x00", "\x85", "\ufeff1", "--- 1", "...", "2", "3", "4", "5", "-0.5", "0.5", "1e-300",
    "5e-324", "1e-320", "1e300", "-1e300",
    "[" * 3000 + "]" * 3000, "- " * 2000 + "1",
]
YAML_KEYS = [
    "[a]", "{a: 1}", "? [a, b]", "1", "~", "true", "1.5", "2001-01-01", "<<", "'kind'", '"hand"',
    "é", "key with space", "-", "*a", "&a k", "!!int k", "!!python/tuple [1]", "?", "", ".inf",
]


def yaml_value() -> st.SearchStrategy[str]:
    """A YAML value as text: odd tags, wrong types, huge and non-finite numbers, unicode."""
    return st.one_of(
        st.sampled_from(YAML_VALUES),
        st.floats().map(repr),
        st.integers(min_value=-(10**450), max_value=10**450).map(str),
        st.text(max_size=12).map(json.dumps),  # a quoted string, any unicode
        st.text(alphabet=st.characters(codec="utf-8"), max_size=8),  # plain text: may break the syntax
    )


def yaml_key(known: list[str]) -> st.SearchStrategy[str]:
    return st.one_of(st.sampled_from(YAML_KEYS), st.sampled_from(known),
                     st.sampled_from(known).map(lambda k: k[:-1]),
                     st.text(alphabet=st.characters(codec="utf-8"), min_size=1, max_size=8))


_KEY_LINE = re.compile(r"^(\s*)(-\s+)?([^:#\s][^:#]*):(.*)$")


def known_keys(text: str) -> list[str]:
    return sorted({m.group(3).strip() for line in text.splitlines() if (m := _KEY_LINE.match(line))})


@st.composite
def mutated_yaml_text(draw: st.DrawFn, base: str) -> str:
    """A valid YAML document with one to three lines changed: a value, a key, a line
    deleted, repeated or inserted, an indentation changed."""
    lines = base.splitlines()
    keys = known_keys(base)
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(lines) - 1))
        m = _KEY_LINE.match(lines[i])
        op = draw(st.sampled_from(["value", "value", "value", "key", "delete", "repeat", "insert",
                                   "indent"]))
        if op == "value" and m:
            lines[i] = f"{m.group(1)}{m.group(2) or ''}{m.group(3)}: {draw(yaml_value())}"
        elif op == "key" and m:
            lines[i] = f"{m.group(1)}{m.group(2) or ''}{draw(yaml_key(keys))}:{m.group(4)}"
        elif op == "delete":
            del lines[i]
        elif op == "repeat":
            lines.insert(i, lines[i])
        elif op == "insert":
            indent = " " * draw(st.sampled_from([0, 2, 4, 6, 1, 3]))
            lines.insert(i, f"{indent}{draw(yaml_key(keys))}: {draw(yaml_value())}")
        else:
            lines[i] = " " * draw(st.integers(0, 6)) + lines[i].lstrip()
        if not lines:
            lines = [""]
    return "\n".join(lines) + "\n"


def python_values() -> st.SearchStrategy[Any]:
    """Any value yaml.dump writes: numbers of every size, NaN, dates, bytes (!!binary),
    tuples and sets (python tags, which a safe loader refuses), nested lists and maps."""
    leaf = st.one_of(st.none(), st.booleans(), st.integers(min_value=-(10**400), max_value=10**400),
                     st.floats(), st.text(max_size=10), st.dates(), st.datetimes(), st.binary(max_size=6),
                     st.integers(-3, 3), st.floats(-1e3, 1e3))
    return st.recursive(leaf, lambda inner: st.one_of(
        st.lists(inner, max_size=3),
        st.dictionaries(st.text(max_size=4) | st.integers(-2, 2), inner, max_size=3),
        st.tuples(inner), st.frozensets(st.integers(0, 3), max_size=2)), max_leaves=5)


def _paths(tree: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [prefix] if prefix else []
    if isinstance(tree, dict):
        for key, value in tree.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(tree, list):
        for i, value in enumerate(tree):
            found += _paths(value, (*prefix, i))
    return found


@st.composite
def mutated_tree_text(draw: st.DrawFn, base: dict[str, Any]) -> str:
    """The base document with one to three keys set to another value, deleted or renamed,
    written by yaml.dump in block or flow style."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(doc)
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for step in path[:-1]:
            parent = parent[step]
        last = path[-1]
        op = draw(st.sampled_from(["set", "set", "set", "delete", "rename"]))
        if op == "set":
            parent[last] = draw(python_values())
        elif op == "delete":
            del parent[last]
        elif isinstance(parent, dict):
            name = draw(st.text(max_size=6) | st.integers() | st.sampled_from(list(parent)))
            parent[name] = parent.pop(last)
    style = draw(st.sampled_from([False, None, True]))
    return yaml.dump(doc, default_flow_style=style, allow_unicode=draw(st.booleans()), sort_keys=False)


# -- CSV ----------------------------------------------------------------------------------
CSV_CELLS = [
    "", " ", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e400", "-1e400", "1e308", "-1e308",
    "1e-400", "5e-324", "0", "-0", "1", "0.01", "1000", "3601", "1e6", "1e12", "9" * 400, "0x10",
    "1_0", " 1 ", "+.5", ".", "-", "e5", "1e", "١٢", "٣", "é", "💥", "\x00", "\x0b", "\"1\"", "'1'",
    "\"a,b\"", "\"", "1,2", "#", "# not a comment", "RUNNING", "vent", "True", "None", "\ufeff0",
]


TIMES = ["1e308", "1.7976931348623157e308", "-1e308", "-1.7976931348623157e308", "1e400", "nan", "3600",
         "3600.01", "1e16", "1e300", "-1", "0", "0.0000001", "5e-324", "0.5", "1.25", "1e-300"]


def csv_cell() -> st.SearchStrategy[str]:
    return st.one_of(st.sampled_from(CSV_CELLS), st.floats(-1e3, 1e3).map(repr), st.floats().map(repr),
                     st.integers(-(10**30), 10**30).map(str),
                     st.text(alphabet=st.characters(codec="utf-8"), max_size=6))


@st.composite
def mutated_csv_text(draw: st.DrawFn, base: str) -> str:
    """A valid CSV with one to four changes: a cell, a header name, a row deleted, repeated,
    swapped or cut, a comment or blank line inserted, the last line cut short."""
    lines = base.splitlines()
    header_at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[header_at].split(",")
    for _ in range(draw(st.integers(1, 4))):
        if len(lines) < 2:
            break
        i = draw(st.integers(0, len(lines) - 1))
        cells = lines[i].split(",")
        op = draw(st.sampled_from(["cell", "cell", "cell", "time", "header", "delete", "repeat", "swap",
                                   "fields", "comment", "blank", "cut", "column"]))
        if op == "time" and "t" in header and i > header_at:  # the time column: huge, negative, equal
            cells[header.index("t") % len(cells)] = draw(st.sampled_from(TIMES) | st.floats().map(repr))
            lines[i] = ",".join(cells)
        elif op == "cell":
            cells[draw(st.integers(0, len(cells) - 1))] = draw(csv_cell())
            lines[i] = ",".join(cells)
        elif op == "header":
            names = lines[header_at].split(",")
            k = draw(st.integers(0, len(names) - 1))
            names[k] = draw(st.sampled_from([*header, "t ", " t", "T", "\ufefft", "t\r", "", "x"])
                            | st.text(max_size=5))
            lines[header_at] = ",".join(names)
        elif op == "delete":
            del lines[i]
        elif op == "repeat":
            lines.insert(i, lines[i])
        elif op == "swap" and i + 1 < len(lines):
            lines[i], lines[i + 1] = lines[i + 1], lines[i]
        elif op == "fields":
            lines[i] = ",".join(cells[: draw(st.integers(0, len(cells) + 1))] or [""]) + draw(
                st.sampled_from(["", ",", ",,1"]))
        elif op == "comment":
            lines.insert(i, draw(st.sampled_from(["#", "# lost: 3 rows before row 9", "# finger: thumb",
                                                  "# key: value", "  # indented", "#:"])))
        elif op == "blank":
            lines.insert(i, draw(st.sampled_from(["", "   ", "\t", ","])))
        elif op == "cut":
            lines = lines[: i + 1]
            lines[-1] = lines[-1][: draw(st.integers(0, len(lines[-1])))]
            return "\n".join(lines)  # no final newline: a writer killed mid-line
        elif op == "column":
            lines = [line if line.startswith("#") else line + "," + (draw(csv_cell()) if k != header_at
                     else draw(st.sampled_from(["t", "extra", "state", "angle_deg"])))
                     for k, line in enumerate(lines)]
    return "\n".join(lines) + "\n"


# -- bytes --------------------------------------------------------------------------------
@st.composite
def encoded(draw: st.DrawFn, text: str) -> bytes:
    """The text as a file might hold it: UTF-8 mostly, maybe with a BOM, CRLF or CR line
    ends, Latin-1 or UTF-16, a few bytes flipped, or cut short."""
    ending = draw(st.sampled_from(["\n", "\n", "\r\n", "\r"]))
    if ending != "\n":
        text = text.replace("\n", ending)
    codec = draw(st.sampled_from(["utf-8", "utf-8", "utf-8", "utf-8-sig", "latin-1", "utf-16"]))
    data = text.encode(codec, errors="replace" if codec == "latin-1" else "surrogatepass")
    if draw(st.integers(0, 9)) == 0 and data:
        for _ in range(draw(st.integers(1, 4))):
            at = draw(st.integers(0, len(data) - 1))
            data = data[:at] + bytes([draw(st.integers(0, 255))]) + data[at + 1:]
    if draw(st.integers(0, 9)) == 0:
        data = data[: draw(st.integers(0, len(data)))]
    return data


def raw_bytes() -> st.SearchStrategy[bytes]:
    """Arbitrary bytes, and arbitrary text encoded."""
    return st.one_of(st.binary(max_size=300),
                     st.text(max_size=200).map(lambda s: s.encode("utf-8", "surrogatepass")))


# -- JSON (the control API) -----------------------------------------------------------------
def json_values() -> st.SearchStrategy[Any]:
    """What json.loads can give, and more (NaN, huge integers, lone surrogates, NUL)."""
    leaf = st.one_of(st.none(), st.booleans(), st.integers(), st.integers(-(10**400), 10**400), st.floats(),
                     st.text(max_size=8), st.sampled_from(["\ud800", "a\x00b", "", "all", "index", "/tmp",
                                                          "/a\x00b", "💥", "vent", "force", "\u202e"]))
    return st.recursive(leaf, lambda inner: st.lists(inner, max_size=3)
                        | st.dictionaries(st.text(max_size=6), inner, max_size=3), max_leaves=6)
