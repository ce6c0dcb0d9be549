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

from hand_service.config.effects import effect_value
from hand_service.config.profile import FingerProfile, Profile
from hand_service.service.plausibility import Mismatch, ModelCheck
from hand_service.transports.base import FirmwareStatus, LinkProblem
from rtcore.gate import (
    CAUSE_ANGLE_OUT_OF_RANGE,
    CAUSE_NON_FINITE,
    CAUSE_SENSOR_REJECTED,
    CAUSE_STALE_SENSOR,
    Gate,
    GateConfig,
)
from rtcore.tick import FOUND_FRAME, FOUND_OUTPUT, FOUND_OVERRUN, FOUND_SAMPLE, Tick


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
    # the bus transport's own checks of the link (transports/checks.py)
    SAMPLE_LATE = "sample_late"
    SAMPLE_LOSS = "sample_loss"
    SEQUENCE_STUCK = "sequence_stuck"
    LATENCY = "latency"
    CLOCK_DRIFT = "clock_drift"
    BUS_ERROR = "bus_error"
    PROTOCOL_CHANGED = "protocol_changed"
    # the model check (service/plausibility.py)
    PRESSURE_LOST = "pressure_lost"
    IMPLAUSIBLE = "implausible"
    # a recording that stopped reaching its file, with recording.on_failure: fault
    RECORDING_FAILED = "recording_failed"


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
        rate_hz = profile.control.rate_hz
        stale_sensor_ticks = int(safety["stale_sensor_ticks"])
        self.core = Gate(GateConfig(
            angle_min_deg=float(safety["angle_min_deg"]),
            angle_max_deg=float(safety["angle_max_deg"]),
            leak_tolerance_kpa=float(safety["leak_tolerance_kpa"]),
            leak_ticks=int(safety["leak_ticks"]),
            stale_sensor_ticks=stale_sensor_ticks,
            sensor_rejected_ticks=stale_sensor_ticks,  # held readings count like stale ones
            overrun_streak=int(safety["overrun_streak"]),
            transport_timeout_ns=int(safety["transport_timeout_ms"] * 1e6),
            pressure_min_kpa=[f.pressure_min_kpa for f in profile.fingers],
            pressure_max_kpa=[f.pressure_max_kpa for f in profile.fingers],
            # the chamber follows the command through the valve's lag and dead time (the
            # finger's effects), approximated by one first-order lag
            follow_alpha=[1.0 - math.exp(-1.0 / (rate_hz * max(_valve_delay_s(f), 1e-9)))
                          for f in profile.fingers]))
        self.firmware_vents: int | None = None  # FirmwareStatus.vents when last seen
        self.model_check = ModelCheck(profile)  # run by the supervisor after each tick

    @property
    def config(self) -> GateConfig:
        return self.core.config

    @property
    def expected_kpa(self) -> np.ndarray:
        return self.core.expected_kpa

    def reset(self) -> None:
        """Forget the history (after a re-handshake)."""
        self.firmware_vents = None
        self.core.reset()
        self.model_check.reset()

    # -- the wording of what a check found -----------------------------------------------
    def first_fault(self, tick: Tick, events: int, hand: Any, transport_fault: Fault | None = None,
                    firmware_fault: Fault | None = None, sequence: int | None = None) -> Fault | None:
        """The fault a tick reports of what its checks found (RTCORE_TICK_* bits in
        events, the results in tick) and the link's own: the first in the order overrun,
        the link, the sample, the frame, the firmware, the outputs."""
        if events & FOUND_OVERRUN:
            return self.overrun_fault(tick.overrun)
        if transport_fault is not None:
            return transport_fault
        if events & FOUND_SAMPLE:
            return self.sample_fault(tick.sample, hand.inputs)
        if events & FOUND_FRAME:
            return self.frame_fault(tick.frame, sequence)
        if firmware_fault is not None:
            return firmware_fault
        if events & FOUND_OUTPUT:
            return self.outputs_fault(tick.output, hand.outputs)
        return None

    def overrun_fault(self, r: Any) -> Fault:
        return Fault(Cause.OVERRUN_STREAK, f"{r.value:.0f} deadline misses in a row "
                     f"(overrun_streak {self.config.overrun_streak})")

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
        config = self.config
        if r.cause == CAUSE_STALE_SENSOR:
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
        config = self.config
        cause, i, limit = r.cause, r.finger, r.limit
        angle, command = outputs.angle_deg[i], outputs.pressure_cmd_kpa[i]
        if cause == CAUSE_NON_FINITE:
            return Fault(Cause.NON_FINITE, f"angle {angle} deg, command {command} kPa", self.names[i])
        if cause == CAUSE_ANGLE_OUT_OF_RANGE:
            return Fault(Cause.ANGLE_OUT_OF_RANGE, f"angle {angle:.1f} deg outside "
                         f"[{config.angle_min_deg:g}, {config.angle_max_deg:g}]", self.names[i])
        if cause == CAUSE_SENSOR_REJECTED:
            return Fault(Cause.SENSOR_REJECTED, f"the sensor reading was implausible for {limit:.0f} "
                         f"ticks in a row; the control step held {angle:.1f} deg "
                         f"(stale_sensor_ticks {config.sensor_rejected_ticks})", self.names[i])
        return Fault(Cause.PRESSURE_OVER_LIMIT, f"command {command:.2f} kPa outside "
                     f"[{limit:g}, {config.pressure_max_kpa[i]:g}] kPa", self.names[i])

    def follow_fault(self, r: Any) -> Fault:
        """Leak or burst: the measured chamber pressure stayed away from where the sent
        command should have taken it for leak_ticks ticks (NaN, not reported, is not
        checked)."""
        config = self.config
        value, limit = r.value, r.limit
        kind = "leak" if value < limit else "stuck or over-pressure"
        return Fault(Cause.LEAK_OR_BURST, f"{kind}: chamber at {value:.1f} kPa where {limit:.1f} "
                     f"kPa was expected, for {config.leak_ticks} ticks "
                     f"(leak_tolerance_kpa {config.leak_tolerance_kpa:g})", self.names[r.finger])

    # -- the link's own checks and the model check ------------------------------------
    @staticmethod
    def link_fault(problem: LinkProblem | None) -> Fault | None:
        """A problem the bus transport's checks found on the link (transports/checks.py)."""
        return None if problem is None else Fault(Cause(problem.kind), problem.detail)

    def model_fault(self, mismatch: Mismatch) -> Fault:
        """What the model check found (plausibility.py) on a finger."""
        return Fault(Cause(mismatch.cause), mismatch.detail, self.names[mismatch.finger])

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


def _valve_delay_s(finger: FingerProfile) -> float:
    """The valve's lag and dead time together (the finger's effects)."""
    effects = finger.model.effects
    return effect_value(effects, "valve_lag") + effect_value(effects, "dead_time")


def finite_or_none(value: float) -> float | None:
    """JSON has no NaN: a missing measurement is null."""
    return value if math.isfinite(value) else None


__all__ = ["Cause", "Fault", "FaultLog", "SafetyGate", "finite_or_none"]
