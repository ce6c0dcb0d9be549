"""Profiles and model files: the shipped ones load; every kind of mistake is one clear line."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.config.model import FingerModel, inertia_from_geometry, save_model
from hand_service.config.profile import DEFAULT_PROFILE, PROFILE_DIR, load_model, load_profile
from hand_service.errors import UserError

SIM = DEFAULT_PROFILE.read_text()


def test_default_profile_is_the_physics_md_hand() -> None:
    profile = load_profile()
    assert profile.finger_names == ["thumb", "index", "middle", "ring", "little"]
    index = profile.finger("index").model
    assert index.inertia_kgm2 == pytest.approx(1.62e-4, rel=0.01)
    assert index.natural_freq_rad_per_s == pytest.approx(59.4, rel=0.01)
    assert index.damping_ratio == pytest.approx(0.161, rel=0.01)
    assert index.lever_arm_m == pytest.approx(0.85 * 0.095 / 2)
    assert profile.finger("middle").pressure_max_kpa == 150
    assert index.effects["valve_lag"]["tau_s"] >= 0.03


@pytest.mark.parametrize("path", sorted(PROFILE_DIR.glob("*.yaml")), ids=lambda p: p.name)
def test_every_shipped_profile_loads(path: Path) -> None:
    load_profile(path).hand_config()


MISTAKES = [
    ("stiffness_nm_per_rad: 0.570", "stifness_nm_per_rad: 0.570",
     r"sim.yaml:\d+: unknown key 'stifness_nm_per_rad' in hand.index "
     r"\(did you mean 'stiffness_nm_per_rad'\?\)"),
    ("rate_hz: 100", "rate_hz: 5000", r"control.rate_hz = 5000 Hz is out of range"),
    ("rate_hz: 100", "rate_hz: fast", r"control.rate_hz must be a number"),
    ("filter_order: 2", "filter_order: 2.5", r"whole number"),
    ("kind: sim", "kind: carrier-pigeon", r"transport.kind must be one of"),
    ("  feedforward: dynamic", "  feedforward: psychic", r"control.feedforward must be one of"),
    ("protocol_version: 1\n", "", r"missing required key 'protocol_version'"),
    ("valve_lag: {tau_s: 0.03}", "valve_lag: {tau_s: -1}", r"valve_lag.tau_s = -1 is out of range"),
    ("valve_lag: {tau_s: 0.03}", "valve_leak: {tau_s: 0.03}", r"unknown key 'valve_leak'.*valve_lag"),
    ("angle_min_deg: -60", "angle_min_deg: 300", r"angle_min_deg must be below"),
    ("  seed: 1", "  seed: 1\n  seed: 2", r'found duplicate key "seed"'),
    ("    pressure_max_kpa: 250\n", "", r"missing required key 'hand.thumb.pressure_max_kpa'"),
    ("    damping_nms_per_rad: 0.0031", "    damping_nms_per_rad: .nan", r"must be finite"),
    ("transport:\n  kind: sim", "transport: [sim]", r"transport must be a mapping"),
]


@pytest.mark.parametrize(("old", "new", "message"), MISTAKES, ids=[m[2][:30] for m in MISTAKES])
def test_profile_mistakes_are_one_clear_line(tmp_path: Path, old: str, new: str, message: str) -> None:
    assert old in SIM, old
    path = tmp_path / "sim.yaml"
    path.write_text(SIM.replace(old, new, 1))
    with pytest.raises(UserError, match=message) as info:
        load_profile(path)
    assert "\n" not in str(info.value)


def test_filter_cutoff_must_lie_below_half_the_rate(tmp_path: Path) -> None:
    """The C core refuses a Butterworth cutoff at or above Nyquist; the profile says where."""
    cutoff_line = SIM.splitlines().index("  filter_cutoff_hz: 25") + 1
    path = tmp_path / "sim.yaml"
    path.write_text(SIM.replace("rate_hz: 100", "rate_hz: 40", 1))
    with pytest.raises(UserError, match=rf"sim.yaml:{cutoff_line}: control.filter_cutoff_hz = 25 Hz must be "
                                        r"below half the control rate \(20 Hz at 40 Hz\)"):
        load_profile(path)
    path.write_text(SIM.replace("rate_hz: 100", "rate_hz: 50", 1))  # exactly Nyquist: refused too
    with pytest.raises(UserError, match="filter_cutoff_hz = 25 Hz"):
        load_profile(path)
    # a bus profile with its own control block over an included hand is checked the same way
    bus = tmp_path / "bus.yaml"
    bus.write_text((PROFILE_DIR / "serial-v1.yaml").read_text()
                   + "\ncontrol:\n  rate_hz: 30\n")
    path.write_text(SIM)
    with pytest.raises(UserError, match=r"bus.yaml:\d+: control.filter_cutoff_hz = 25 Hz .* at 30 Hz"):
        load_profile(bus)
    bus.write_text(bus.read_text() + "  filter_cutoff_hz: 12\n")
    assert load_profile(bus).hand_config().sample_rate_hz == 30


def test_bad_yaml_syntax_names_the_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("profile: x\nhand:\n  index: {mass_kg: 0.05\n")
    with pytest.raises(UserError, match=r"broken.yaml:\d+"):
        load_profile(path)


def test_model_file_round_trip_and_profile_finger(tmp_path: Path) -> None:
    model = load_model(DEFAULT_PROFILE, finger="ring")
    assert model.finger == "ring"
    path = tmp_path / "ring.yaml"
    save_model(model, path, header="written by a test")
    again = load_model(path)
    assert again.to_dict() == model.to_dict()


def test_model_needs_inertia_or_geometry(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    path.write_text("stiffness_nm_per_rad: 0.5\n")
    with pytest.raises(UserError, match="give inertia_kgm2, or mass_kg, length_m and gamma"):
        load_model(path)
    path.write_text("mass_kg: 0.05\nlength_m: 0.095\ngamma: 0.85\n")
    assert load_model(path).inertia_kgm2 == pytest.approx(inertia_from_geometry(0.05, 0.095, 0.85))


def test_missing_parameter_is_named() -> None:
    with pytest.raises(UserError, match="no 'stiffness_nm_per_rad', needed for control"):
        FingerModel(inertia_kgm2=1e-4).require("stiffness_nm_per_rad", purpose="control")


def test_profile_needs_a_finger_name_for_a_model() -> None:
    with pytest.raises(UserError, match="pick one with --finger"):
        load_model(DEFAULT_PROFILE)
    with pytest.raises(UserError, match="no finger 'pinky'"):
        load_model(DEFAULT_PROFILE, finger="pinky")


def test_a_wire_that_cannot_carry_0_kpa_is_refused(tmp_path: Path) -> None:
    """Every vent is a 0 kPa command: a DBC whose pressure command starts above 0 could never vent."""
    from hand_service.config.profile import _check_command_range

    fingers = load_profile(None).fingers
    _check_command_range(fingers, (-100.0, 600.0, "ValveCommand.pressure_cmd_kpa"), tmp_path / "p.yaml")
    with pytest.raises(UserError, match="leaves out 0 kPa"):
        _check_command_range(fingers, (10.0, 600.0, "ValveCommand.pressure_cmd_kpa"), tmp_path / "p.yaml")


def test_a_profile_without_a_safety_section_takes_the_documented_defaults(tmp_path: Path) -> None:
    """`safety` is optional (docs/formats.md): a profile without it loads with every limit at
    its default (the fuzzer found a KeyError here)."""
    lines = SIM.splitlines(keepends=True)
    start = next(i for i, line in enumerate(lines) if line.startswith("safety:"))
    end = next(i for i in range(start + 1, len(lines)) if lines[i].strip() and not lines[i].startswith(" "))
    path = tmp_path / "sim.yaml"
    path.write_text("".join(lines[:start] + lines[end:]))
    from hand_service.config.safety import SAFETY_SECTION

    safety = load_profile(path).safety
    assert safety == {key.name: key.default for key in SAFETY_SECTION.keys}
