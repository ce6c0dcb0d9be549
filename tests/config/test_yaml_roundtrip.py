"""Profile edits through ruamel.yaml's round trip: the changed values and nothing else.

`calibrate ... --update-profile` on a profile full of comments, quoted strings, flow
mappings and blank lines: a diff of the file before and after shows only the changed
values' lines."""

from __future__ import annotations

import difflib
import re
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from hand_service.config.yamlio import load_yaml
from hand_service.config.yamlupdate import set_values, update_values
from hand_service.errors import UserError
from hand_service.identification import trials


def commented_profile(path: Path) -> Path:
    """sim.yaml with a comment after every scalar of the hand, a quoted description, blank
    lines between the fingers and a document start."""
    lines = []
    for line in DEFAULT_PROFILE.read_text().splitlines():
        if line.startswith("description:"):
            line = "description: 'a lab''s hand: \"five\" fingers'   # quoted, single"
        elif line.startswith("profile:"):
            line = 'profile: "sim"  # quoted, double'
        elif re.match(r"    \w+: [^{#]+$", line):
            line = f"{line}    # measured 2026-11-20"
        elif re.match(r"  \w+:$", line) and not line.startswith("  kind"):
            lines.append("")
            lines.append(f"  # -- {line.strip()[:-1]} --")
        lines.append(line)
    path.write_text("---\n" + "\n".join(lines) + "\n")
    return path


def changed_lines(before: str, after: str) -> list[tuple[str, str]]:
    """The (-, +) line pairs of a diff of the two texts; no line added or removed alone."""
    diff = [d for d in difflib.ndiff(before.splitlines(), after.splitlines()) if d[:2] in ("- ", "+ ")]
    removed = [d[2:] for d in diff if d.startswith("- ")]
    added = [d[2:] for d in diff if d.startswith("+ ")]
    assert len(removed) == len(added), diff
    return list(zip(removed, added, strict=True))


def test_calibrate_gain_changes_only_its_value(tmp_path: Path) -> None:
    profile = load_profile()
    mine = commented_profile(tmp_path / "mine.yaml")
    before = mine.read_text()
    assert load_profile(mine).finger("middle").model.pressure_gain_nm_per_kpa == 1.2101e-2
    middle = profile.finger("middle")
    sweep = trials.pressure_sweep(middle, profile.simulation, seed=7).write(tmp_path / "s.csv")
    assert main(["calibrate", "gain", str(sweep), "--model", str(mine), "--finger", "middle",
                 "--update-profile", str(mine)]) == 0
    after = mine.read_text()
    ((old, new),) = changed_lines(before, after)
    assert old == "    pressure_gain_nm_per_kpa: 1.2101e-2    # measured 2026-11-20"
    value = load_profile(mine).finger("middle").model.pressure_gain_nm_per_kpa
    assert new.split("#")[0].rstrip() == f"    pressure_gain_nm_per_kpa: {value!r}"
    assert new.index("# measured 2026-11-20") == old.index("#")  # the comment at its column
    assert value != pytest.approx(1.2101e-2, rel=1e-6) and value == pytest.approx(1.2101e-2, rel=0.05)


def test_calibrate_sensor_and_valve_change_only_their_values(tmp_path: Path) -> None:
    profile = load_profile()
    mine = commented_profile(tmp_path / "mine.yaml")
    before = mine.read_text()
    little = profile.finger("little")
    pairs = trials.sensor_pairs(little, profile.simulation, seed=3).write(tmp_path / "p.csv")
    valve = trials.valve_steps(profile.finger("ring"), profile.simulation, seed=4).write(tmp_path / "v.csv")
    assert main(["calibrate", "sensor", str(pairs), "--update-profile", str(mine)]) == 0
    assert main(["calibrate", "valve", str(valve), "--model", str(mine), "--finger", "ring",
                 "--update-profile", str(mine)]) == 0
    changed = changed_lines(before, mine.read_text())
    keys = [re.match(r"\s*([\w-]+):", old).group(1) for old, _ in changed]  # type: ignore[union-attr]
    # in the file's order: the ring's valve, then the little finger's sensor (its gain may
    # come out as it was, to the 7 digits written)
    assert keys in (["valve_lag", "dead_time", "sensor_gain_deg_per_mv", "sensor_offset_deg"],
                    ["valve_lag", "dead_time", "sensor_offset_deg"]), changed
    for old, new in changed:
        assert old.split("#")[1:] == new.split("#")[1:]  # the comment after the value kept
        if "#" in old:  # at its column, unless the longer value pushed it on
            assert old.index("#") == new.index("#") or len(new.split("#")[0]) >= old.index("#")
    assert changed[0][1].startswith("      valve_lag: {tau_s: ")  # still a flow mapping
    little = load_profile(mine).finger("little")
    assert little.sensor_offset_deg != profile.finger("little").sensor_offset_deg


def test_values_keys_quoting_and_order(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    text = ("# a comment at the top\n"
            "name: 'single'   # kept as it was quoted\n"
            "hand:\n"
            "    index:                 # four-space indents stay four\n"
            "        stiffness_nm_per_rad: 0.570   # from identify\n"
            "        effects:\n"
            "            valve_lag: {tau_s: 0.03}  # the valve\n"
            "    thumb: {stiffness_nm_per_rad: 0.65}\n"
            "list: [1, 2]\n"
            'other: "double"\n')
    new = set_values(text, [(("hand", "index", "stiffness_nm_per_rad"), 0.5712345678),
                            (("hand", "thumb", "damping_nms_per_rad"), 0.001),
                            (("hand", "index", "effects", "dead_time", "delay_s"), 0.005)], path)
    assert new.splitlines() == [
        "# a comment at the top",
        "name: 'single'   # kept as it was quoted",
        "hand:",
        "    index:                 # four-space indents stay four",
        "        stiffness_nm_per_rad: 0.5712346 # from identify",  # at its column, or one space on
        "        effects:",
        "            valve_lag: {tau_s: 0.03}  # the valve",
        "            dead_time:",
        "                delay_s: 0.005",
        "    thumb: {stiffness_nm_per_rad: 0.65, damping_nms_per_rad: 0.001}",
        "list: [1, 2]",
        'other: "double"',
    ]
    path.write_text(new)
    assert list(load_yaml(path)["hand"]["index"]) == ["stiffness_nm_per_rad", "effects"]
    with pytest.raises(UserError, match=r"m.yaml:6: 'hand.index.effects' is a mapping, not a value"):
        set_values(text, [(("hand", "index", "effects"), 1.0)], path)
    with pytest.raises(UserError, match=r"m.yaml:2: 'name' is not a mapping"):
        set_values(text, [(("name", "x"), 1.0)], path)
    with pytest.raises(UserError, match=r"m.yaml:3: not valid YAML"):
        set_values("a: 1\nb: [\n", [], path)


def test_every_shipped_profile_comes_back_unchanged_without_updates() -> None:
    for path in sorted(DEFAULT_PROFILE.parent.glob("*.yaml")):
        assert set_values(path.read_text(), [], path) == path.read_text(), path.name


def test_an_invalid_result_leaves_the_file_alone(tmp_path: Path) -> None:
    path = tmp_path / "sim.yaml"
    path.write_text(DEFAULT_PROFILE.read_text())
    with pytest.raises(UserError, match=r"not updated.*pressure_gain_nm_per_kpa"):
        update_values(path, [(("hand", "ring", "pressure_gain_nm_per_kpa"), -1.0)], load_profile)
    assert path.read_text() == DEFAULT_PROFILE.read_text()
    assert not list(tmp_path.glob(".*updating"))


def test_a_mapping_used_as_a_key_is_refused_in_one_line(tmp_path: Path) -> None:
    """A block mapping under a `?` key makes ruamel test a mapping as a dict key (TypeError);
    the fuzzer's input, refused as bad YAML."""
    path = tmp_path / "m.yaml"
    path.write_text("gamma: 0.85\n? [a, b]:\n  valve_lag: {tau_s: 0.03}\n  dead_time: {delay_s: 0.005}\n")
    with pytest.raises(UserError, match=r"m.yaml: not valid YAML: a mapping used as a key") as raised:
        load_yaml(path)
    assert "\n" not in str(raised.value)
