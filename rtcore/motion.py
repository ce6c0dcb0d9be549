"""Fingers' dynamics alone, in C (csrc/rtcore_sim_plant.h) through cffi, for a caller that
drives each chamber itself and adds an external torque (the pinch experiment's contacts).

    motions = FingerMotions([SimFinger(...), ...])
    motions.advance(input_kpa, external_torque_nm, duration_s)   # arrays of len(fingers)
    motions.angle_rad                                            # numpy views of the C state

The simulated hand (rtcore.sim.Simulator) steps the same dynamics under its valve and
sensors.
"""

from __future__ import annotations

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.config import ConfigError
from rtcore.hand import _fill, error_message
from rtcore.sim import SimFinger

# rtcore_sim_motion's fields, in their C order
MOTION_FIELDS = ("angle_rad", "velocity_rad_per_s", "chamber_kpa", "hysteresis_z", "creep_angle_rad",
                 "max_step_s")


class FingerMotions:
    """Several independent fingers in caller-owned C memory, all at rest and vented until
    `start` places them; each advances under its own held input and external torque."""

    def __init__(self, fingers: list[SimFinger]) -> None:
        if not fingers:
            raise ConfigError("FingerMotions needs at least one finger")
        self.n_fingers = len(fingers)
        self._fingers = ffi.new("rtcore_sim_finger[]", self.n_fingers)
        self._motions = ffi.new("rtcore_sim_motion[]", self.n_fingers)
        self._caches = ffi.new("rtcore_propagator_cache[]", self.n_fingers)  # each finger's, kept
        for i, finger in enumerate(fingers):
            _fill(self._fingers[i], finger)
            self.start(i, 0.0)
        dtype = np.dtype({"names": list(MOTION_FIELDS), "formats": [np.float64] * len(MOTION_FIELDS),
                          "offsets": [ffi.offsetof("rtcore_sim_motion", name) for name in MOTION_FIELDS],
                          "itemsize": ffi.sizeof("rtcore_sim_motion")})
        state = np.frombuffer(ffi.buffer(self._motions), dtype=dtype)
        self.angle_rad: np.ndarray = state["angle_rad"]
        self.velocity_rad_per_s: np.ndarray = state["velocity_rad_per_s"]
        self.chamber_kpa: np.ndarray = state["chamber_kpa"]
        self._input = np.zeros(self.n_fingers)
        self._torque = np.zeros(self.n_fingers)
        self._input_ptr = ffi.cast("double *", ffi.from_buffer(self._input))
        self._torque_ptr = ffi.cast("double *", ffi.from_buffer(self._torque))

    def start(self, finger: int, angle_deg: float, velocity_deg_per_s: float = 0.0,
              chamber_kpa: float = 0.0) -> None:
        """Place one finger (its hysteresis loop at its middle)."""
        code = lib.rtcore_sim_motion_start(self._fingers + finger, self._motions + finger,
                                           self._caches + finger, angle_deg, velocity_deg_per_s, chamber_kpa)
        if code != lib.RTCORE_OK:
            raise ConfigError(error_message(code, finger))

    def move_contact(self, finger: int, angle_deg: float) -> None:
        """Move one finger's object (its SimFinger's contact, a spring-damper at the force
        point) to angle_deg: a wall that comes down on the finger."""
        self._fingers[finger].contact_angle_deg = angle_deg

    def advance(self, input_kpa: np.ndarray, external_torque_nm: np.ndarray, duration_s: float) -> None:
        """Every finger duration_s on: its valve's input held at input_kpa[i] (the chamber
        itself for a finger without a valve lag) and external_torque_nm[i] held (positive
        bends the finger)."""
        self._input[:] = np.ravel(input_kpa)
        self._torque[:] = np.ravel(external_torque_nm)
        lib.rtcore_sim_motion_advance_many(self._fingers, self._motions, self._caches, self._input_ptr,
                                           self._torque_ptr, self.n_fingers, duration_s)
