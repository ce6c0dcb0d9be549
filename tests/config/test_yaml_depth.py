"""Flow collections nested past MAX_FLOW_DEPTH are refused before ruamel's scanner reads
them (its time grows with the square of the depth); brackets in quotes and comments, and any
depth up to the bound, are read as YAML."""

from __future__ import annotations

import pytest

from hand_service.config.yamlio import MAX_FLOW_DEPTH, flow_too_deep, parse_yaml
from hand_service.errors import UserError


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


def test_one_level_past_the_bound_is_refused_by_the_depth_check() -> None:
    with pytest.raises(UserError, match=f"more than {MAX_FLOW_DEPTH} levels of"):
        parse_yaml("seed: " + nested(MAX_FLOW_DEPTH + 1), "deep.yaml")
    with pytest.raises(UserError, match="more than"):  # a mapping's braces count as well
        parse_yaml("seed: " + "{a: " * (MAX_FLOW_DEPTH + 1) + "1" + "}" * (MAX_FLOW_DEPTH + 1), "deep.yaml")


def test_the_bound_itself_is_read() -> None:
    value = parse_yaml("seed: " + nested(MAX_FLOW_DEPTH), "deep.yaml")["seed"]
    for _ in range(MAX_FLOW_DEPTH - 1):
        value = value[0]
    assert value == []


@pytest.mark.parametrize("text", [
    "description: '" + "[" * 300 + "'",                 # single-quoted
    'description: "' + "{" * 300 + '"',                 # double-quoted
    'description: "a \\" quote ' + "[" * 300 + '"',       # an escaped quote inside
    "seed: 1   # " + "[" * 300,                         # a comment
    "name: finger's " + "x" * 3 + "\nnote: '" + "[" * 300 + "'",  # an apostrophe in a plain scalar
])
def test_brackets_in_quotes_and_comments_are_not_nesting(text: str) -> None:
    assert not flow_too_deep(text)
    parse_yaml(text, "quoted.yaml")


def test_a_plain_apostrophe_does_not_hide_the_nesting_after_it() -> None:
    assert flow_too_deep("name: finger's\nseed: " + nested(MAX_FLOW_DEPTH + 1))
