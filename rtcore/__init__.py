"""rtcore: the hand's control step in C (csrc/), its cffi binding and a Python reference."""

from rtcore.arrays import Inputs, Outputs
from rtcore.config import (
    FF_DYNAMIC,
    FF_NONE,
    FF_QUASI_STATIC,
    FLAG_INTEGRATOR_HELD,
    FLAG_MODE_CHANGED,
    FLAG_MODE_REJECTED,
    FLAG_NOT_CONFIGURED,
    FLAG_OUTPUT_REJECTED,
    FLAG_RATE_LIMITED,
    FLAG_REFERENCE_REJECTED,
    FLAG_SATURATED,
    FLAG_SENSOR_REJECTED,
    MAX_FINGERS,
    MODE_FORCE,
    MODE_IMPEDANCE,
    MODE_POSITION,
    MODE_PRESSURE,
    MODE_VENT,
    ConfigError,
    Effects,
    FingerConfig,
    HandConfig,
    Prbm,
    flag_names,
)
from rtcore.hand import Hand, butter_design
from rtcore.reference import ReferenceHand

__all__ = [
    "FF_DYNAMIC", "FF_NONE", "FF_QUASI_STATIC", "FLAG_INTEGRATOR_HELD", "FLAG_MODE_CHANGED",
    "FLAG_MODE_REJECTED", "FLAG_NOT_CONFIGURED", "FLAG_OUTPUT_REJECTED", "FLAG_RATE_LIMITED",
    "FLAG_REFERENCE_REJECTED", "FLAG_SATURATED", "FLAG_SENSOR_REJECTED", "MAX_FINGERS",
    "MODE_FORCE", "MODE_IMPEDANCE", "MODE_POSITION", "MODE_PRESSURE", "MODE_VENT", "ConfigError", "Effects",
    "FingerConfig", "Hand", "HandConfig", "Inputs", "Outputs", "Prbm", "ReferenceHand",
    "butter_design", "flag_names",
]
