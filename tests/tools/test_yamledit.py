"""In-place YAML updates: values replaced on their line, comments kept, keys added, and a
bad result refused without touching the file."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from hand_service.config.yamledit import set_value, update_values
from hand_service.config.yamlio import load_yaml
from hand_service.errors import UserError

TEXT = """\
# a comment at the top
hand:
  index:
    stiffness_nm_per_rad: 0.570   # from identify
    effects:
      valve_lag: {tau_s: 0.03}  # the valve
  thumb: {stiffness_nm_per_rad: 0.65}
"""


def edit(tmp_path: Path, keys: tuple[str, ...], value: object) -> str:
    path = tmp_path / "m.yaml"
    return set_value(TEXT, keys, value, path)


def test_values_are_replaced_on_their_line(tmp_path: Path) -> None:
    text = edit(tmp_path, ("hand", "index", "stiffness_nm_per_rad"), 0.5712345678)
    assert "    stiffness_nm_per_rad: 0.5712346   # from identify" in text
    text = edit(tmp_path, ("hand", "index", "effects", "valve_lag", "tau_s"), 0.0301)
    assert "      valve_lag: {tau_s: 0.0301}  # the valve" in text
    text = edit(tmp_path, ("hand", "thumb", "stiffness_nm_per_rad"), 0.7)
    assert "  thumb: {stiffness_nm_per_rad: 0.7}" in text
    assert text.count("\n") == TEXT.count("\n")


def test_missing_keys_and_mappings_are_added(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    text = set_value(TEXT, ("hand", "index", "pressure_gain_nm_per_kpa"), 0.009, path)
    text = set_value(text, ("hand", "index", "effects", "dead_time", "delay_s"), 0.005, path)
    path.write_text(text)
    data = load_yaml(path)
    assert data["hand"]["index"]["pressure_gain_nm_per_kpa"] == 0.009
    assert data["hand"]["index"]["effects"] == {"valve_lag": {"tau_s": 0.03}, "dead_time": {"delay_s": 0.005}}
    assert "# from identify" in text and "# the valve" in text
    with pytest.raises(UserError, match="flow mapping"):
        set_value(TEXT, ("hand", "thumb", "damping_nms_per_rad"), 0.001, path)
    with pytest.raises(UserError, match="is a mapping, not a value"):
        set_value(TEXT, ("hand", "index", "effects"), 1.0, path)


def test_a_profile_update_keeps_every_other_line(tmp_path: Path) -> None:
    path = tmp_path / "sim.yaml"
    original = DEFAULT_PROFILE.read_text()
    path.write_text(original)
    update_values(path, [(("hand", "ring", "pressure_gain_nm_per_kpa"), 0.00801),
                         (("hand", "ring", "sensor_offset_deg"), -48.25)], load_profile)
    before, after = original.splitlines(), path.read_text().splitlines()
    changed = [(a, b) for a, b in zip(before, after, strict=True) if a != b]
    assert changed == [("    pressure_gain_nm_per_kpa: 7.9624e-3", "    pressure_gain_nm_per_kpa: 0.00801"),
                       ("    sensor_offset_deg: -49.0", "    sensor_offset_deg: -48.25")]
    assert load_profile(path).finger("ring").model.pressure_gain_nm_per_kpa == 0.00801


def test_an_invalid_result_leaves_the_file_alone(tmp_path: Path) -> None:
    path = tmp_path / "sim.yaml"
    path.write_text(DEFAULT_PROFILE.read_text())
    with pytest.raises(UserError, match=r"not updated.*pressure_gain_nm_per_kpa"):
        update_values(path, [(("hand", "ring", "pressure_gain_nm_per_kpa"), -1.0)], load_profile)
    assert path.read_text() == DEFAULT_PROFILE.read_text()
    assert not list(tmp_path.glob(".*updating"))
