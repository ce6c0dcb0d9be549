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
from typing import Any

import numpy as np

from hand_service.effects import effect_value
from hand_service.profile import Profile
from hand_service.transports.base import FirmwareStatus
from rtcore._rtcore import ffi, lib


class Cause(str, enum.Enum):
    HANDSHAKE_FAILED = "handshake_failed"
    STALE_SENSOR = "stale_sensor"
    ANGLE_OUT_OF_RANGE = "angle_out_of_range"
    PRESSURE_OVER_LIMIT = "pressure_over_limit"
    NON_FINITE = "non_finite"
    TRANSPORT_LOST = "transport_lost"
    OVERRUN_STREAK = "overrun_streak"
    FIRMWARE_FAULT = "firmware_fault"
    FIRMWARE_VENTED = "firmware_vented"
    LEAK_OR_BURST = "leak_or_burst"
    SENSOR_REJECTED = "sensor_rejected"


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
    """The checks in C (csrc/rtcore_gate.c), run by the tick (csrc/rtcore_tick.c) on the
    control step's own structs: no conversion and no allocation unless a check fails, when
    the Fault is worded here from what the check found (an rtcore_gate_result)."""

    def __init__(self, profile: Profile) -> None:
        safety = profile.safety
        self.names = profile.finger_names
        rate_hz = profile.control["rate_hz"]
        self._gate = ffi.new("rtcore_gate *")
        config = self._gate.config
        config.n_fingers = len(profile.fingers)
        config.angle_min_deg = float(safety["angle_min_deg"])
        config.angle_max_deg = float(safety["angle_max_deg"])
        config.leak_tolerance_kpa = float(safety["leak_tolerance_kpa"])
        config.leak_ticks = int(safety["leak_ticks"])
        config.stale_sensor_ticks = int(safety["stale_sensor_ticks"])
        config.sensor_rejected_ticks = config.stale_sensor_ticks  # held readings count like stale ones
        config.overrun_streak = int(safety["overrun_streak"])
        config.transport_timeout_ns = int(safety["transport_timeout_ms"] * 1e6)
        for i, f in enumerate(profile.fingers):
            config.pressure_min_kpa[i] = f.pressure_min_kpa
            config.pressure_max_kpa[i] = f.pressure_max_kpa
            # the chamber follows the command through the valve's lag and dead time (the
            # finger's effects), approximated by one first-order lag
            lag_s = (effect_value(f.model.effects, "valve_lag")
                     + effect_value(f.model.effects, "dead_time"))
            config.follow_alpha[i] = 1.0 - math.exp(-1.0 / (rate_hz * max(lag_s, 1e-9)))
        self.reset()

    @property
    def c_gate(self) -> object:
        """The rtcore_gate struct (cdata pointer) the tick runs the checks on."""
        return self._gate

    @property
    def expected_kpa(self) -> np.ndarray:
        return np.array(self._gate.expected_kpa[0:len(self.names)])

    def reset(self) -> None:
        """Forget the history (after a re-handshake)."""
        self.firmware_vents: int | None = None  # FirmwareStatus.vents when last seen
        lib.rtcore_gate_reset(self._gate)

    # -- the wording of what a check found -----------------------------------------------
    def first_fault(self, c_tick: Any, events: int, hand: Any, transport_fault: Fault | None = None,
                    firmware_fault: Fault | None = None, sequence: int | None = None) -> Fault | None:
        """The fault a tick reports of what its checks found (RTCORE_TICK_* bits in
        events, the results in c_tick) and the link's own: the first in the order overrun,
        the link, the sample, the frame, the firmware, the outputs."""
        if events & lib.RTCORE_TICK_OVERRUN:
            return self.overrun_fault(c_tick.overrun)
        if transport_fault is not None:
            return transport_fault
        if events & lib.RTCORE_TICK_SAMPLE:
            return self.sample_fault(c_tick.sample, hand.inputs)
        if events & lib.RTCORE_TICK_FRAME:
            return self.frame_fault(c_tick.frame, sequence)
        if firmware_fault is not None:
            return firmware_fault
        if events & lib.RTCORE_TICK_OUTPUT:
            return self.outputs_fault(c_tick.output, hand.outputs)
        return None

    def overrun_fault(self, r: Any) -> Fault:
        return Fault(Cause.OVERRUN_STREAK, f"{r.value:.0f} deadline misses in a row "
                     f"(overrun_streak {self._gate.config.overrun_streak})")

    def frame_fault(self, r: Any, sequence: int | None) -> Fault:
        """Stale sensor or lost transport (rtcore_gate_frame).

        Freshness is judged on the firmware's clock: the transport counts, by the firmware's
        sequence, the samples that never reached it, so stale_sensor_ticks of them in a row are
        a stale sensor. Samples that did arrive but were replaced by a newer one before the
        tick took it (a host that ticked late) are not lost. A tick with no new sample is
        not by itself a stale sensor either: the firmware's clock and the host's tick beat
        against each other, and scheduling on either side delays and bunches the frames.
        Silence on the host's clock is bounded by transport_timeout_ms.
        """
        config = self._gate.config
        if r.cause == lib.RTCORE_GATE_STALE_SENSOR:
            upto = f"up to sequence {sequence}; " if sequence is not None else ""
            return Fault(Cause.STALE_SENSOR, f"{r.value:.0f} sensor samples in a row never arrived "
                         f"({upto}stale_sensor_ticks {config.stale_sensor_ticks})")
        return Fault(Cause.TRANSPORT_LOST, f"no sensor frame for {r.value / 1e6:.0f} ms "
                     f"(transport_timeout_ms {config.transport_timeout_ns / 1e6:g})")

    def sample_fault(self, r: Any, inputs: Any) -> Fault:
        """The hand's inputs as received: every sensor finite; a measured pressure finite
        or NaN (not reported), never infinite."""
        i = r.finger
        if not math.isfinite(inputs.sensor_mv[i]):
            return Fault(Cause.NON_FINITE, f"sensor reads {r.value} mV", self.names[i])
        return Fault(Cause.NON_FINITE, f"measured pressure {r.value} kPa", self.names[i])

    def outputs_fault(self, r: Any, outputs: Any) -> Fault:
        """The controller's result before it is sent: finite, in range, within limits."""
        config = self._gate.config
        cause, i, limit = r.cause, r.finger, r.limit
        angle, command = outputs.angle_deg[i], outputs.pressure_cmd_kpa[i]
        if cause == lib.RTCORE_GATE_NON_FINITE:
            return Fault(Cause.NON_FINITE, f"angle {angle} deg, command {command} kPa", self.names[i])
        if cause == lib.RTCORE_GATE_ANGLE_OUT_OF_RANGE:
            return Fault(Cause.ANGLE_OUT_OF_RANGE, f"angle {angle:.1f} deg outside "
                         f"[{config.angle_min_deg:g}, {config.angle_max_deg:g}]", self.names[i])
        if cause == lib.RTCORE_GATE_SENSOR_REJECTED:
            return Fault(Cause.SENSOR_REJECTED, f"the sensor reading was implausible for {limit:.0f} "
                         f"ticks in a row; the control step held {angle:.1f} deg "
                         f"(stale_sensor_ticks {config.sensor_rejected_ticks})", self.names[i])
        return Fault(Cause.PRESSURE_OVER_LIMIT, f"command {command:.2f} kPa outside "
                     f"[{limit:g}, {config.pressure_max_kpa[i]:g}] kPa", self.names[i])

    def follow_fault(self, r: Any) -> Fault:
        """Leak or burst: the measured chamber pressure stayed away from where the sent
        command should have taken it for leak_ticks ticks (NaN, not reported, is not
        checked)."""
        config = self._gate.config
        value, limit = r.value, r.limit
        kind = "leak" if value < limit else "stuck or over-pressure"
        return Fault(Cause.LEAK_OR_BURST, f"{kind}: chamber at {value:.1f} kPa where {limit:.1f} "
                     f"kPa was expected, for {config.leak_ticks} ticks "
                     f"(leak_tolerance_kpa {config.leak_tolerance_kpa:g})", self.names[r.finger])

    # -- firmware --------------------------------------------------------------------
    def firmware(self, status: FirmwareStatus, commanding: bool) -> Fault | None:
        """A fault the firmware reports of its own, and, while the supervisor commands
        (`commanding`: RUNNING, HOLD), a vent it did not ask for: the board's watchdog (the
        host stalled, or its commands did not get through), its own fault or a reboot. The
        next command would step the chamber from 0 kPa to where the rate limit had taken
        it. A fault injected on the debug port is not the board's (it shows as what it does)."""
        vents, self.firmware_vents = self.firmware_vents, status.vents
        if status.fault_code:
            return Fault(Cause.FIRMWARE_FAULT, f"firmware reports fault {status.fault_code}"
                         + (f": {status.fault_text}" if status.fault_text else ""))
        if commanding and vents is not None and status.vents > vents:
            return Fault(Cause.FIRMWARE_VENTED, f"the firmware vented every valve on its own "
                         f"(now {status.state or 'vented'}): its watchdog saw no command for "
                         f"firmware_watchdog_ms, or it rebooted")
        return None


def finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a missing measurement is null."""
    return value if math.isfinite(value) else None


__all__ = ["Cause", "Fault", "FaultLog", "SafetyGate", "finite_or_none"]
