"""The safety gate: every tick it checks the inputs, the controller's outputs and the
health of the link against the profile's `safety:` limits, and names any fault.

The C core already saturates and rejects non-finite values; the gate checks again, in
different code, because a fault here must vent even if the core is wrong.
"""

from __future__ import annotations

import enum
import math
import time
from dataclasses import dataclass, field

import numpy as np

from hand_service.profile import Profile


class Cause(str, enum.Enum):
    HANDSHAKE_FAILED = "handshake_failed"
    STALE_SENSOR = "stale_sensor"
    ANGLE_OUT_OF_RANGE = "angle_out_of_range"
    PRESSURE_OVER_LIMIT = "pressure_over_limit"
    NON_FINITE = "non_finite"
    TRANSPORT_LOST = "transport_lost"
    OVERRUN_STREAK = "overrun_streak"
    FIRMWARE_FAULT = "firmware_fault"
    LEAK_OR_BURST = "leak_or_burst"


@dataclass
class Fault:
    cause: Cause
    detail: str
    finger: str | None = None
    t_s: float = 0.0  # supervisor time (s since start)
    wall_time: str = ""  # ISO 8601, local

    def as_dict(self) -> dict[str, object]:
        return {"cause": self.cause.value, "detail": self.detail, "finger": self.finger,
                "t_s": round(self.t_s, 4), "wall_time": self.wall_time}


@dataclass
class FaultLog:
    """Every fault with its time and cause, and a count per cause."""

    faults: list[Fault] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    limit: int = 1000  # the oldest are dropped beyond this; the counts keep growing

    def add(self, fault: Fault, t_s: float) -> Fault:
        fault.t_s = t_s
        fault.wall_time = time.strftime("%Y-%m-%dT%H:%M:%S%z")
        self.faults.append(fault)
        del self.faults[:-self.limit]
        self.counts[fault.cause.value] = self.counts.get(fault.cause.value, 0) + 1
        return fault

    @property
    def total(self) -> int:
        return sum(self.counts.values())


class SafetyGate:
    """Per-tick checks. Each check returns a Fault or None; nothing here allocates
    beyond that."""

    def __init__(self, profile: Profile) -> None:
        safety = profile.safety
        self.names = profile.finger_names
        rate_hz = profile.control["rate_hz"]
        self.stale_ticks = int(safety["stale_sensor_ticks"])
        self.timeout_ns = int(safety["transport_timeout_ms"] * 1e6)
        self.angle_min_deg = float(safety["angle_min_deg"])
        self.angle_max_deg = float(safety["angle_max_deg"])
        self.overrun_streak = int(safety["overrun_streak"])
        self.leak_tolerance_kpa = float(safety["leak_tolerance_kpa"])
        self.leak_ticks = int(safety["leak_ticks"])
        self.pressure_min_kpa = np.array([f.pressure_min_kpa for f in profile.fingers])
        self.pressure_max_kpa = np.array([f.pressure_max_kpa for f in profile.fingers])
        # the chamber is expected to follow the command through the valve's lag and dead
        # time (the finger's effects), approximated by one first-order lag
        lag_s = np.array([f.model.effects.get("valve_lag", {}).get("tau_s", 0.0)
                          + f.model.effects.get("dead_time", {}).get("delay_s", 0.0)
                          for f in profile.fingers])
        self.follow_alpha = 1.0 - np.exp(-1.0 / (rate_hz * np.maximum(lag_s, 1e-9)))
        n = len(self.names)
        self.expected_kpa = np.zeros(n)
        self.leak_count = np.zeros(n, dtype=np.int64)
        self._scratch = np.zeros(n)
        self.reset()

    def reset(self) -> None:
        """Forget the history (after a re-handshake)."""
        self.missed = 0
        self.last_frame_ns: int | None = None
        self.overruns = 0
        self.expected_kpa[:] = 0.0
        self.leak_count[:] = 0

    # -- inputs ----------------------------------------------------------------------
    def frame(self, fresh: bool, now_ns: int) -> Fault | None:
        """Whether this tick brought a fresh frame: stale sensor, transport lost."""
        if fresh:
            self.missed = 0
            self.last_frame_ns = now_ns
            return None
        self.missed += 1
        if self.last_frame_ns is None:
            self.last_frame_ns = now_ns
        silent_ns = now_ns - self.last_frame_ns
        if silent_ns >= self.timeout_ns:
            return Fault(Cause.TRANSPORT_LOST, f"no frame for {silent_ns / 1e6:.0f} ms "
                         f"(transport_timeout_ms {self.timeout_ns / 1e6:g})")
        if self.missed >= self.stale_ticks:
            return Fault(Cause.STALE_SENSOR, f"no fresh sensor frame for {self.missed} ticks "
                         f"(stale_sensor_ticks {self.stale_ticks})")
        return None

    def sample(self, sensor_mv: np.ndarray, pressure_meas_kpa: np.ndarray) -> Fault | None:
        """Raw values: every sensor finite; a measured pressure is finite or NaN (not
        reported), never infinite."""
        if not np.isfinite(sensor_mv).all():
            i = int(np.flatnonzero(~np.isfinite(sensor_mv))[0])
            return Fault(Cause.NON_FINITE, f"sensor reads {sensor_mv[i]} mV", self.names[i])
        if np.isinf(pressure_meas_kpa).any():
            i = int(np.flatnonzero(np.isinf(pressure_meas_kpa))[0])
            return Fault(Cause.NON_FINITE, f"measured pressure {pressure_meas_kpa[i]} kPa",
                         self.names[i])
        return None

    # -- outputs ---------------------------------------------------------------------
    def outputs(self, angle_deg: np.ndarray, pressure_cmd_kpa: np.ndarray) -> Fault | None:
        """The controller's result before it is sent: finite, in range, within limits."""
        if not (np.isfinite(angle_deg).all() and np.isfinite(pressure_cmd_kpa).all()):
            bad = ~(np.isfinite(angle_deg) & np.isfinite(pressure_cmd_kpa))
            i = int(np.flatnonzero(bad)[0])
            return Fault(Cause.NON_FINITE, f"angle {angle_deg[i]} deg, command "
                         f"{pressure_cmd_kpa[i]} kPa", self.names[i])
        low, high = angle_deg.min(), angle_deg.max()
        if low < self.angle_min_deg or high > self.angle_max_deg:
            i = int(np.argmin(angle_deg) if low < self.angle_min_deg else np.argmax(angle_deg))
            return Fault(Cause.ANGLE_OUT_OF_RANGE, f"angle {angle_deg[i]:.1f} deg outside "
                         f"[{self.angle_min_deg:g}, {self.angle_max_deg:g}]", self.names[i])
        over = np.subtract(pressure_cmd_kpa, self.pressure_max_kpa, out=self._scratch)
        if over.max() > 0.0 or (pressure_cmd_kpa < self.pressure_min_kpa).any():
            bad = (pressure_cmd_kpa > self.pressure_max_kpa) | (pressure_cmd_kpa < self.pressure_min_kpa)
            i = int(np.flatnonzero(bad)[0])
            return Fault(Cause.PRESSURE_OVER_LIMIT, f"command {pressure_cmd_kpa[i]:.2f} kPa outside "
                         f"[{self.pressure_min_kpa[i]:g}, {self.pressure_max_kpa[i]:g}] kPa",
                         self.names[i])
        return None

    def follow(self, sent_kpa: np.ndarray, pressure_meas_kpa: np.ndarray) -> Fault | None:
        """Leak or burst: the measured chamber pressure stays away from where the command
        should have taken it for leak_ticks ticks (NaN, not reported, is not checked)."""
        expected = self.expected_kpa
        deviation = np.abs(pressure_meas_kpa - expected)
        outside = deviation > self.leak_tolerance_kpa
        self.leak_count += outside
        self.leak_count[~outside] = 0
        # the expectation for the next tick: the command just sent, through the lag
        expected += self.follow_alpha * (sent_kpa - expected)
        if self.leak_count.max() >= self.leak_ticks:
            i = int(np.argmax(self.leak_count))
            kind = "leak" if pressure_meas_kpa[i] < expected[i] else "stuck or over-pressure"
            return Fault(Cause.LEAK_OR_BURST, f"{kind}: chamber at {pressure_meas_kpa[i]:.1f} kPa "
                         f"where {expected[i]:.1f} kPa was expected, for {self.leak_ticks} ticks "
                         f"(leak_tolerance_kpa {self.leak_tolerance_kpa:g})", self.names[i])
        return None

    # -- timing and firmware ---------------------------------------------------------
    def overrun(self, missed_deadline: bool) -> Fault | None:
        self.overruns = self.overruns + 1 if missed_deadline else 0
        if self.overruns >= self.overrun_streak:
            return Fault(Cause.OVERRUN_STREAK, f"{self.overruns} deadline misses in a row "
                         f"(overrun_streak {self.overrun_streak})")
        return None

    @staticmethod
    def firmware(fault_code: int, fault_text: str) -> Fault | None:
        if fault_code:
            return Fault(Cause.FIRMWARE_FAULT, f"firmware reports fault {fault_code}"
                         + (f": {fault_text}" if fault_text else ""))
        return None


def finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a missing measurement is null."""
    return value if math.isfinite(value) else None


__all__ = ["Cause", "Fault", "FaultLog", "SafetyGate", "finite_or_none"]
