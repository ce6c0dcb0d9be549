"""Firmware profiles (firmware_profiles/*.yaml): one rig, validated on load.

A profile names the transport and its settings, the wire-protocol version the firmware
must report, control settings, safety limits, the simulated truth (for `sim` and the
mock firmware) and the hand: one block per finger with the model keys of docs/formats.md
plus the sensor calibration, pressure limits and gains. Unknown keys are refused with
the file, line and nearest known key; every key is documented in docs/profiles.md,
which is generated from the sections below.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Any

import rtcore
from hand_service.config.control import CONTROL_SECTION, ControlSettings, cutoff_problem
from hand_service.config.model import MODEL_KEYS, MODEL_SECTION, FingerModel, model_from_mapping
from hand_service.config.pneumatics import PNEUMATICS_SECTION, VALVE_MODEL_KEYS, check_pneumatics
from hand_service.config.recording import RECORDING_SECTION, RecordingSettings
from hand_service.config.safety import SAFETY_SECTION, check_safety
from hand_service.config.schema import Key, Section, expect_mapping, fail, validate
from hand_service.config.textfile import lookup, printable, show
from hand_service.config.transports import KINDS
from hand_service.config.tuning import INTEGRAL_RATE_PER_S, margin_gains
from hand_service.config.yamlio import LineDict, load_yaml
from hand_service.errors import UserError, where

ROOT = Path(__file__).resolve().parents[2]  # the checkout (docs/); site-packages once installed


def _shipped_profiles() -> Path:
    """firmware_profiles/ of the repository, installed as hand_service.firmware_profiles (setup.py)."""
    try:
        return Path(str(files("hand_service.firmware_profiles")))
    except ModuleNotFoundError:  # a checkout on sys.path without an install
        return ROOT / "firmware_profiles"


PROFILE_DIR = _shipped_profiles()
DEFAULT_PROFILE = PROFILE_DIR / "sim.yaml"

TOP_SECTION = Section("Profile", "The top level of a profile.", (
    Key("profile", "the profile's name", "str"),
    Key("description", "one line for people", "str", default=""),
    Key("protocol_version", "wire-protocol version the firmware must report", "int", min=1,
        max=65535),
    Key("include", "another profile, relative to this one, whose control, safety, simulation "
        "and hand sections are used where this file does not give them", "str", default=""),
    Key("transport", "how to reach the valve board (see Transport)", "mapping"),
    Key("control", "control settings (see Control)", "mapping", default=None),
    Key("safety", "safety limits and watchdog times (see Safety)", "mapping", default=None),
    Key("simulation", "the simulated truth for `sim` and the mock firmware", "mapping",
        default=None),
    Key("hand", "one block per finger, keyed by finger name (see Finger); required unless "
        "included", "mapping", default=None),
    Key("recording", "what a recording failure does (see Recording)", "mapping", default=None),
))

SIMULATION_SECTION = Section(
    "Simulation", "`simulation:` — the simulated hand's truth (the hand's own model plus these).", (
        Key("seed", "random seed: the same seed gives the same run", "int", "", 1, 0, 2**63 - 1),
        Key("sensor_noise_deg", "flex-sensor noise, one standard deviation", "float", "deg", 0.3,
            0.0, 20.0),
        Key("adc_step_mv", "ADC quantisation step (0: none)", "float", "mV", 1.22, 0.0, 100.0),
        Key("pressure_noise_kpa", "noise on the measured chamber pressure", "float", "kPa", 0.5,
            0.0, 100.0),
        Key("substeps", "integration sub-steps per sample (1 ms or finer at 100 Hz)", "int", "",
            10, 1, 1000),
        *VALVE_MODEL_KEYS,
    ))

FINGER_EXTRA_SECTION = Section(
    "Finger", "`hand.<name>:` — the model keys of docs/formats.md (below) plus these.", (
        Key("sensor_gain_deg_per_mv", "flex sensor calibration: deg = gain·mV + offset; not 0",
            "float", "deg/mV", 0.1),
        Key("sensor_offset_deg", "flex sensor calibration offset", "float", "deg", 0.0),
        Key("pressure_min_kpa", "lowest pressure command", "float", "kPa", 0.0, -100.0, 1000.0),
        Key("pressure_max_kpa", "highest pressure command (the finger's limit)", "float", "kPa",
            min=0.0, max=1000.0, min_exclusive=True),
        Key("pressure_rate_max_kpa_per_s", "fastest change of the command", "float", "kPa/s",
            2000.0, 0.0, None, True),
        Key("kp_kpa_per_deg", "position PID: proportional gain; absent: the finger's critical "
            "gain / 3 from its own model (hand_service/config/tuning.py)", "float", "kPa/deg", None, 0.0),
        Key("ki_kpa_per_deg_s", "position PID: integral gain; absent: 10/s · kp", "float",
            "kPa/(deg·s)", None, 0.0),
        Key("kd_kpa_s_per_deg", "position PID: derivative gain", "float", "kPa·s/deg", 0.0, 0.0),
        Key("force_kp_kpa_per_n", "force PI: proportional gain", "float", "kPa/N", 2.0, 0.0),
        Key("force_ki_kpa_per_n_s", "force PI: integral gain", "float", "kPa/(N·s)", 20.0, 0.0),
    ))
FINGER_EXTRA_KEYS = tuple(k.name for k in FINGER_EXTRA_SECTION.keys)

PRESSURE_LIMIT_KEYS = ("pressure_min_kpa", "pressure_max_kpa")
FINGER_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,31}")
INCLUDED_SECTIONS = ("control", "safety", "simulation", "hand")


@dataclass
class FingerProfile:
    name: str
    model: FingerModel
    sensor_gain_deg_per_mv: float
    sensor_offset_deg: float
    pressure_min_kpa: float
    pressure_max_kpa: float
    pressure_rate_max_kpa_per_s: float
    kp_kpa_per_deg: float | None
    ki_kpa_per_deg_s: float | None
    kd_kpa_s_per_deg: float
    force_kp_kpa_per_n: float
    force_ki_kpa_per_n_s: float
    gains_from_model: bool = False  # kp/ki were absent and came from tuning.margin_gains
    # file:line of each pressure limit (for a bus profile that checks an included hand) and
    # of the finger's block ("model")
    lines: dict[str, str] = field(default_factory=dict, repr=False, compare=False)

    def rtcore_config(self, control: ControlSettings, **overrides: float) -> rtcore.FingerConfig:
        return rtcore.FingerConfig(
            prbm=self.model.prbm(f"controlling finger '{self.name}'"),
            sensor_gain_deg_per_mv=self.sensor_gain_deg_per_mv,
            sensor_offset_deg=self.sensor_offset_deg,
            filter_order=control.filter_order,
            filter_cutoff_hz=control.filter_cutoff_hz,
            velocity_cutoff_hz=control.velocity_cutoff_hz,
            feedforward=rtcore.config.FEEDFORWARD_BY_NAME[control.feedforward],
            force_estimate_dynamic=int(control.force_estimate == "dynamic"),
            force_estimate_hysteresis=int(control.force_estimate_hysteresis),
            kp_kpa_per_deg=self.kp_kpa_per_deg,
            ki_kpa_per_deg_s=self.ki_kpa_per_deg_s,
            kd_kpa_s_per_deg=self.kd_kpa_s_per_deg,
            derivative_cutoff_hz=control.derivative_cutoff_hz,
            integrator_limit_kpa=control.integrator_limit_kpa,
            force_kp_kpa_per_n=self.force_kp_kpa_per_n,
            force_ki_kpa_per_n_s=self.force_ki_kpa_per_n_s,
            pressure_min_kpa=self.pressure_min_kpa,
            pressure_max_kpa=self.pressure_max_kpa,
            pressure_rate_max_kpa_per_s=self.pressure_rate_max_kpa_per_s,
        ).replace(**overrides)


@dataclass
class Profile:
    path: Path
    name: str
    description: str
    protocol_version: int
    transport: dict[str, Any]
    control: ControlSettings
    safety: dict[str, Any]
    simulation: dict[str, Any]
    fingers: list[FingerProfile] = field(default_factory=list)
    recording: RecordingSettings = field(default_factory=RecordingSettings)
    # file:line of the control keys a rate given on the command line is checked against
    lines: dict[str, str] = field(default_factory=dict, repr=False, compare=False)

    @property
    def finger_names(self) -> list[str]:
        return [f.name for f in self.fingers]

    def finger(self, name: str | None) -> FingerProfile:
        if name is None:
            raise UserError(f"{self.path}: a profile holds several fingers; pick one with "
                            f"--finger ({', '.join(self.finger_names)})")
        for f in self.fingers:
            if f.name == name:
                return f
        raise UserError(f"{self.path}: no finger '{name}' (fingers: {', '.join(self.finger_names)})")

    def hand_config(self) -> rtcore.HandConfig:
        return rtcore.HandConfig([f.rtcore_config(self.control) for f in self.fingers],
                                 sample_rate_hz=self.control.rate_hz)


def _section(data: Any, key: str, section: Section, source: Path) -> dict[str, Any]:
    block = data.get(key)
    if block is None:
        block = {}
    return validate(expect_mapping(block, source, data, key, key), section, source, key)


def _finger(name: str, block: Any, source: Path, hand: Any) -> FingerProfile:
    if not FINGER_NAME.fullmatch(name) or name == "all":
        raise fail(source, hand, name, f"hand: the finger name {show(name)} must be a letter, then up to "
                   "31 letters, digits, '_' or '-' (it names CSV columns and API targets), and not 'all'")
    context = f"hand.{name}"
    block = expect_mapping(block, source, hand, name, context)
    model, rest = model_from_mapping(block, source, context, extra=FINGER_EXTRA_KEYS)
    if model.finger not in (None, name):
        raise fail(source, block, "finger", f"{context}.finger says '{model.finger}'")
    model.finger = name
    extra = validate(rest, FINGER_EXTRA_SECTION, source, context)
    if extra["sensor_gain_deg_per_mv"] == 0.0:
        raise fail(source, block, "sensor_gain_deg_per_mv", f"{context}.sensor_gain_deg_per_mv must not be 0")
    if extra["pressure_min_kpa"] >= extra["pressure_max_kpa"]:
        raise fail(source, block, "pressure_min_kpa",
                   f"{context}: pressure_min_kpa must be below pressure_max_kpa")
    lines = {key: where(source, block.line_of(key)) for key in PRESSURE_LIMIT_KEYS}
    lines["model"] = where(source, block.line)
    return FingerProfile(name=name, model=model, **extra, lines=lines)


def _control(data: Any, source: Path) -> tuple[ControlSettings, dict[str, str]]:
    """The control section, its filter checked against its rate, and the line of each key."""
    control = ControlSettings.from_values(_section(data, "control", CONTROL_SECTION, source))
    block = data.get("control")
    lines = {f"control.{key}": where(source, block.line_of(key) if isinstance(block, LineDict)
                                     else getattr(data, "line", None))
             for key in ("rate_hz", "filter_cutoff_hz")}
    problem = cutoff_problem(control, control.rate_hz)
    if problem is not None:
        key = "filter_cutoff_hz" if isinstance(block, dict) and "filter_cutoff_hz" in block else "rate_hz"
        raise UserError(f"{lines[f'control.{key}']}: {problem}")
    return control, lines


def _check_command_range(fingers: list[FingerProfile], carried: tuple[float, float, str],
                         source: Path) -> None:
    """Every finger's pressure limits within what the transport's wire carries: a command is
    never clipped on its way to the valves."""
    low, high, what = carried
    if not low <= 0.0 <= high:
        raise UserError(f"{source}: {what} carries {low:g}..{high:g} kPa, which leaves out 0 kPa: "
                        f"the host could never vent")
    for finger in fingers:
        for key in PRESSURE_LIMIT_KEYS:
            value = getattr(finger, key)
            if not low <= value <= high:
                raise UserError(f"{finger.lines.get(key, source)}: hand.{finger.name}.{key} = {value:g} kPa, "
                                f"but {what} carries {low:g}..{high:g} kPa (transport of {source}): "
                                f"lower the limit, or widen the signal")


def _fill_gains(finger: FingerProfile, control: ControlSettings) -> None:
    """Absent PI gains come from the finger's model by gain margin (tuning.py)."""
    if finger.kp_kpa_per_deg is not None and finger.ki_kpa_per_deg_s is not None:
        return
    provisional = finger.rtcore_config(control, kp_kpa_per_deg=0.0, ki_kpa_per_deg_s=0.0)
    gains = margin_gains(provisional, control.rate_hz)
    if not 0.0 < gains.kp_kpa_per_deg < math.inf:
        raise UserError(f"{finger.lines.get('model', '?')}: hand.{finger.name}: its model gives no usable "
                        f"position gains (kp = {gains.kp_kpa_per_deg:g} kPa/deg): check its stiffness, "
                        "damping, pressure gain, inertia and control.filter_cutoff_hz, or give "
                        "kp_kpa_per_deg and ki_kpa_per_deg_s")
    finger.gains_from_model = True
    if finger.kp_kpa_per_deg is None:
        finger.kp_kpa_per_deg = gains.kp_kpa_per_deg
    if finger.ki_kpa_per_deg_s is None:
        finger.ki_kpa_per_deg_s = INTEGRAL_RATE_PER_S * finger.kp_kpa_per_deg


def load_profile(path: str | Path | None = None) -> Profile:
    """Load and validate a profile; any mistake is a one-line UserError naming the line."""
    source = Path(path) if path is not None else DEFAULT_PROFILE
    if lookup(source) is None and source.parent == Path(".") and lookup(PROFILE_DIR / source) is not None:
        source = PROFILE_DIR / source  # `--profile sim.yaml` finds the shipped profiles
    data = load_yaml(source)
    top = validate(data, TOP_SECTION, source)
    transport_block = expect_mapping(top["transport"], source, data, "transport", "transport")
    kind = transport_block.get("kind")
    if not isinstance(kind, str) or kind not in KINDS:
        raise fail(source, transport_block, "kind",
                   f"transport.kind must be one of {', '.join(sorted(KINDS))}, not {show(kind)}")
    transport_kind = KINDS[kind]
    transport = validate(transport_block, transport_kind.section, source, "transport")
    if transport_kind.check is not None:
        transport_kind.check(transport, source, transport_block)
    base = _included(source, data, top["include"]) if top["include"] else None
    if top["hand"] is None and base is None:
        raise fail(source, data, None, "missing required key 'hand' (one block per finger), or "
                   "'include' a profile that has one")

    def own(key: str) -> bool:
        return base is None or key in data

    control, lines = _control(data, source) if own("control") else (base.control, base.lines)
    if own("safety"):
        safety = _section(data, "safety", SAFETY_SECTION, source)
        check_safety(safety, control.rate_hz, source, data.get("safety"))
    else:
        safety = base.safety
    simulation = (_section(data, "simulation", SIMULATION_SECTION, source) if own("simulation")
                  else base.simulation)
    if own("simulation"):
        check_pneumatics(simulation, source, data.get("simulation"))
    if top["hand"] is None:
        # the included hand, with gains it took from its model derived again for this
        # profile's control settings (rate, filter)
        fingers = [dataclasses.replace(f, kp_kpa_per_deg=None, ki_kpa_per_deg_s=None)
                   if f.gains_from_model else f for f in base.fingers]
    else:
        hand = expect_mapping(top["hand"], source, data, "hand", "hand")
        if not 1 <= len(hand) <= rtcore.MAX_FINGERS:
            raise fail(source, data, "hand",
                       f"hand must have 1 to {rtcore.MAX_FINGERS} fingers, not {len(hand)}")
        fingers = [_finger(str(name), block, source, hand) for name, block in hand.items()]
    for finger in fingers:
        _fill_gains(finger, control)
    if transport_kind.command_range is not None:
        _check_command_range(fingers, transport_kind.command_range(transport), source)
    return Profile(path=source, name=top["profile"], description=top["description"],
                   protocol_version=top["protocol_version"], transport=transport, control=control,
                   safety=safety, simulation=simulation, fingers=fingers, lines=lines,
                   recording=RecordingSettings.from_profile(data, source))


def _included(source: Path, data: Any, include: str) -> Profile:
    """The included profile, validated in its own file (one level deep: no include there)."""
    path = Path(include) if Path(include).is_absolute() else source.parent / include
    try:
        kind = lookup(path)
    except UserError as exc:
        raise fail(source, data, "include", f"include: {exc}") from None
    if kind is None:
        raise fail(source, data, "include", f"include: {printable(str(path))} not found")
    if kind != "file":  # never a FIFO or a device: reading one may never end
        raise fail(source, data, "include", f"include: {printable(str(path))} is not a regular file")
    raw = load_yaml(path)
    if isinstance(raw, dict) and raw.get("include"):
        raise fail(source, data, "include", f"include: {path} includes another profile itself; "
                   "include a profile that stands alone")
    return load_profile(path)


def load_model(path: str | Path, finger: str | None = None) -> FingerModel:
    """A model file, or one finger of a profile (`hand:` block) chosen by `finger`."""
    data = load_yaml(path)
    if not isinstance(data, dict):
        raise UserError(f"{path}: a model file is a mapping of keys (docs/formats.md), "
                        f"not {type(data).__name__}")
    if "hand" in data or "profile" in data:  # a profile, its hand its own or included
        return load_profile(path).finger(finger).model
    model, _ = model_from_mapping(data, path)
    if finger is not None and model.finger is not None and model.finger != finger:
        raise UserError(f"{path}: this model is for finger {show(model.finger)}, not {show(finger)}")
    if model.finger is None and finger is not None:
        model.finger = finger
    return model


def all_sections() -> list[Section]:
    return [TOP_SECTION, *(kind.section for kind in KINDS.values()), CONTROL_SECTION, SAFETY_SECTION,
            SIMULATION_SECTION, PNEUMATICS_SECTION, RECORDING_SECTION, FINGER_EXTRA_SECTION, MODEL_SECTION]


__all__ = ["DEFAULT_PROFILE", "MODEL_KEYS", "MODEL_SECTION", "PROFILE_DIR", "FingerProfile",
           "Profile", "all_sections", "load_model", "load_profile", "where"]
