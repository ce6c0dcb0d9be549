"""The per-finger input and output arrays of one control step.

Field names are the C names in csrc/rtcore.h. For the C core the arrays are numpy views
into the C structs (mapped once); the reference implementation owns plain arrays.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np


@dataclass
class Inputs:
    sensor_mv: np.ndarray
    pressure_meas_kpa: np.ndarray
    mode: np.ndarray
    angle_ref_deg: np.ndarray
    velocity_ref_deg_per_s: np.ndarray
    accel_ref_deg_per_s2: np.ndarray
    jerk_ref_deg_per_s3: np.ndarray
    force_ref_n: np.ndarray
    pressure_ref_kpa: np.ndarray
    impedance_stiffness_n_per_deg: np.ndarray
    impedance_damping_n_s_per_deg: np.ndarray


@dataclass
class Outputs:
    pressure_cmd_kpa: np.ndarray
    angle_deg: np.ndarray
    angle_filt_deg: np.ndarray
    velocity_deg_per_s: np.ndarray
    accel_deg_per_s2: np.ndarray
    feedforward_kpa: np.ndarray
    pid_kpa: np.ndarray
    chamber_pressure_kpa: np.ndarray
    force_normal_n: np.ndarray
    force_est_x_n: np.ndarray
    force_est_y_n: np.ndarray
    force_magnitude_n: np.ndarray
    flags: np.ndarray


INTEGER_FIELDS = {"mode": np.int32, "flags": np.uint32}


def field_names(cls: type) -> list[str]:
    return [f.name for f in dataclasses.fields(cls)]


def allocate(cls: type, n_fingers: int) -> Inputs | Outputs:
    """Arrays owned by Python, zeroed, NaN for the measured pressure (not reported)."""
    arrays = {
        name: np.zeros(n_fingers, dtype=INTEGER_FIELDS.get(name, np.float64))
        for name in field_names(cls)
    }
    if cls is Inputs:
        arrays["pressure_meas_kpa"][:] = np.nan
    return cls(**arrays)
