"""The safety gate's checks in C (rtcore_gate, csrc/rtcore_gate.c): their settings, their
history and what a check found, for the supervisor to word as a fault.

The tick (rtcore.tick) runs the checks on the control step's own structs; this module
owns the gate struct and names the causes a check reports.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.config import MAX_FINGERS

# what a check found (GateResult.cause)
CAUSE_OK = lib.RTCORE_GATE_OK
CAUSE_NON_FINITE = lib.RTCORE_GATE_NON_FINITE
CAUSE_ANGLE_OUT_OF_RANGE = lib.RTCORE_GATE_ANGLE_OUT_OF_RANGE
CAUSE_PRESSURE_OVER_LIMIT = lib.RTCORE_GATE_PRESSURE_OVER_LIMIT
CAUSE_LEAK_OR_BURST = lib.RTCORE_GATE_LEAK_OR_BURST
CAUSE_SENSOR_REJECTED = lib.RTCORE_GATE_SENSOR_REJECTED
CAUSE_OVERRUN_STREAK = lib.RTCORE_GATE_OVERRUN_STREAK
CAUSE_STALE_SENSOR = lib.RTCORE_GATE_STALE_SENSOR
CAUSE_TRANSPORT_LOST = lib.RTCORE_GATE_TRANSPORT_LOST


@dataclass
class GateConfig:
    """The gate's settings, field for field rtcore_gate_config (csrc/rtcore_gate.h).

    follow_alpha: the measured chamber pressure is expected to follow the sent command
    through a first-order lag, expected += follow_alpha · (sent − expected) every tick.
    """

    angle_min_deg: float
    angle_max_deg: float
    leak_tolerance_kpa: float
    leak_ticks: int
    stale_sensor_ticks: int
    sensor_rejected_ticks: int
    overrun_streak: int
    transport_timeout_ns: int
    pressure_min_kpa: list[float] = field(default_factory=list)
    pressure_max_kpa: list[float] = field(default_factory=list)
    follow_alpha: list[float] = field(default_factory=list)

    @property
    def n_fingers(self) -> int:
        return len(self.pressure_max_kpa)


class Gate:
    """An rtcore_gate with its settings; `c_gate` is the struct the tick runs on."""

    def __init__(self, config: GateConfig) -> None:
        n = config.n_fingers
        per_finger = len(config.pressure_min_kpa) == len(config.follow_alpha) == n
        if not per_finger or not 1 <= n <= MAX_FINGERS:
            raise ValueError(f"one pressure limit pair and one follow_alpha per finger, "
                             f"1 to {MAX_FINGERS} fingers")
        self.config = config
        self.c_gate = ffi.new("rtcore_gate *")
        c = self.c_gate.config
        c.n_fingers = n
        for name in ("angle_min_deg", "angle_max_deg", "leak_tolerance_kpa"):
            setattr(c, name, float(getattr(config, name)))
        for name in ("leak_ticks", "stale_sensor_ticks", "sensor_rejected_ticks", "overrun_streak",
                     "transport_timeout_ns"):
            setattr(c, name, int(getattr(config, name)))
        for i in range(n):
            c.pressure_min_kpa[i] = config.pressure_min_kpa[i]
            c.pressure_max_kpa[i] = config.pressure_max_kpa[i]
            c.follow_alpha[i] = config.follow_alpha[i]
        self.reset()

    def reset(self) -> None:
        """Forget the history: streaks, the expected chamber pressures, the last frame."""
        lib.rtcore_gate_reset(self.c_gate)

    @property
    def expected_kpa(self) -> np.ndarray:
        """Where each chamber's pressure should be by now, from the commands sent."""
        return np.array(self.c_gate.expected_kpa[0:self.config.n_fingers])


__all__ = ["CAUSE_ANGLE_OUT_OF_RANGE", "CAUSE_LEAK_OR_BURST", "CAUSE_NON_FINITE", "CAUSE_OK",
           "CAUSE_OVERRUN_STREAK", "CAUSE_PRESSURE_OVER_LIMIT", "CAUSE_SENSOR_REJECTED",
           "CAUSE_STALE_SENSOR", "CAUSE_TRANSPORT_LOST", "Gate", "GateConfig"]
