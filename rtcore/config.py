"""Typed configuration of the control step, field for field the C structs of csrc/rtcore.h.

The field names are the C names, so the wrapper copies them by name and a test checks
that the two sets stay equal. `Prbm` (the C rtcore_prbm) is the one declaration of a
finger's model parameters: the controller's `FingerConfig` and the simulator's
`SimFinger` (rtcore/sim.py) both hold one as their field `prbm`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, TypeVar

MAX_FINGERS = 8

MODE_VENT = 0
MODE_PRESSURE = 1
MODE_POSITION = 2
MODE_FORCE = 3
MODE_IMPEDANCE = 4
MODE_NAMES = {MODE_VENT: "vent", MODE_PRESSURE: "pressure", MODE_POSITION: "position",
              MODE_FORCE: "force", MODE_IMPEDANCE: "impedance"}
MODES_BY_NAME = {name: mode for mode, name in MODE_NAMES.items()}

FF_NONE = 0
FF_QUASI_STATIC = 1
FF_DYNAMIC = 2
FEEDFORWARD_BY_NAME = {"none": FF_NONE, "quasi_static": FF_QUASI_STATIC, "dynamic": FF_DYNAMIC}

FLAG_SATURATED = 1
FLAG_RATE_LIMITED = 2
FLAG_SENSOR_REJECTED = 4
FLAG_REFERENCE_REJECTED = 8
FLAG_INTEGRATOR_HELD = 16
FLAG_MODE_REJECTED = 32
FLAG_OUTPUT_REJECTED = 64
FLAG_NOT_CONFIGURED = 128
FLAG_MODE_CHANGED = 256
FLAG_NAMES = {
    FLAG_SATURATED: "saturated",
    FLAG_RATE_LIMITED: "rate_limited",
    FLAG_SENSOR_REJECTED: "sensor_rejected",
    FLAG_REFERENCE_REJECTED: "reference_rejected",
    FLAG_INTEGRATOR_HELD: "integrator_held",
    FLAG_MODE_REJECTED: "mode_rejected",
    FLAG_OUTPUT_REJECTED: "output_rejected",
    FLAG_NOT_CONFIGURED: "not_configured",
    FLAG_MODE_CHANGED: "mode_changed",
}


def flag_names(flags: int) -> list[str]:
    """The names of the bits set in a flags word, lowest bit first."""
    return [name for bit, name in FLAG_NAMES.items() if flags & bit]


@dataclass
class Effects:
    """Physics beyond the plain PRBM that the controller compensates (docs/formats.md effects)."""

    valve_lag_tau_s: float = 0.0
    valve_vent_tau_s: float = 0.0  # the lag while the chamber vents; 0: valve_lag_tau_s both ways
    dead_time_s: float = 0.0
    coulomb_torque_nm: float = 0.0
    coulomb_smoothing_deg_per_s: float = 2.0
    cubic_stiffness_nm_per_rad3: float = 0.0
    gravity_torque_nm: float = 0.0
    asymmetric_stiffness_ratio: float = 1.0
    quadratic_damping_nms2_per_rad2: float = 0.0
    pressure_deadzone_kpa: float = 0.0
    # a contact met past contact_onset_deg: max(Kc·(θ − θc)^n + Cc·θ', 0), a spring with a
    # Kelvin-Voigt damper Cc while in contact, pushing only; stiffness 0 means none
    contact_stiffness_nm_per_radn: float = 0.0
    contact_onset_deg: float = 0.0
    contact_exponent: float = 1.0
    contact_damping_nms_per_rad: float = 0.0
    # the chamber pressure stiffens the finger: k·(1 + c·p_eff/p_ref); gain 0 means none
    pressure_stiffening_gain: float = 0.0
    pressure_stiffening_ref_kpa: float = 100.0
    # creep: a standard-linear-solid branch, a spring ratio·k in series with a dashpot of time
    # constant creep_time_s (the position feedforward keeps its own copy); ratio 0 means none
    creep_stiffness_ratio: float = 0.0
    creep_time_s: float = 1.0
    # hysteresis: the controller's model of the finger's loop −H·z (Dahl's, z turning toward
    # the motion within travel_deg); the position feedforward adds H·z with z driven by the
    # reference. The simulator's loop is SimFinger.hysteresis_*; torque 0 means none
    hysteresis_torque_nm: float = 0.0
    hysteresis_travel_deg: float = 5.0


@dataclass
class Prbm:
    """A finger's PRBM, A θ'' + B θ' + k θ = N p − Jᵀ F (docs/physics.md §1), with its effects.

    A in kg·m², B in N·m·s/rad, k in N·m/rad, N in N·m/kPa, r (|J|, pivot to force
    point) in m; θ in rad, p in kPa, F in N.
    """

    inertia_kgm2: float
    damping_nms_per_rad: float
    stiffness_nm_per_rad: float
    pressure_gain_nm_per_kpa: float
    lever_arm_m: float
    effects: Effects = field(default_factory=Effects)


PRBM_FIELDS = frozenset(f.name for f in dataclasses.fields(Prbm))

_Finger = TypeVar("_Finger", bound="HasPrbm")


class HasPrbm:
    """A finger dataclass with a field `prbm`: `replace` takes the PRBM's field names too."""

    prbm: Prbm

    def replace(self: _Finger, **changes: Any) -> _Finger:
        """A copy with `changes`; the names of Prbm fields (effects too) change `prbm`."""
        inner = {name: changes.pop(name) for name in list(changes) if name in PRBM_FIELDS}
        if inner:
            changes["prbm"] = dataclasses.replace(changes.get("prbm", self.prbm), **inner)
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]


@dataclass
class FingerConfig(HasPrbm):
    """One finger: its PRBM, sensor calibration, filters, controller and pressure limits."""

    prbm: Prbm
    sensor_gain_deg_per_mv: float = 1.0
    sensor_offset_deg: float = 0.0
    filter_order: int = 2
    filter_cutoff_hz: float = 25.0
    velocity_cutoff_hz: float = 25.0
    feedforward: int = FF_DYNAMIC
    force_estimate_dynamic: int = 0
    force_estimate_hysteresis: int = 0
    kp_kpa_per_deg: float = 0.2
    ki_kpa_per_deg_s: float = 2.0
    kd_kpa_s_per_deg: float = 0.0
    derivative_cutoff_hz: float = 10.0
    integrator_limit_kpa: float = 50.0
    force_kp_kpa_per_n: float = 2.0
    force_ki_kpa_per_n_s: float = 20.0
    pressure_min_kpa: float = 0.0
    pressure_max_kpa: float = 200.0
    pressure_rate_max_kpa_per_s: float = 2000.0


@dataclass
class HandConfig:
    """A hand of 1 to 8 fingers stepped together at one sample rate."""

    fingers: list[FingerConfig]
    sample_rate_hz: float = 100.0

    @property
    def n_fingers(self) -> int:
        return len(self.fingers)

    @property
    def dt_s(self) -> float:
        return 1.0 / self.sample_rate_hz


class ConfigError(ValueError):
    """The C core refused a configuration; the message names the finger and the rule."""
