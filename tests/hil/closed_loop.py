"""The C control step driven through a transport at the firmware's pace: the closed-loop
step the HIL suite runs against the mock, the host build and the QEMU image alike."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

import rtcore
from hand_service.config.profile import Profile

# A loop that waited longer than this for a sample, skipped more of them, or whose commands
# reached the firmware later, was not the 100 Hz loop the gains were tuned for
LOOP_WAIT_LIMIT_PERIODS = 5
LOOP_SKIPPED_LIMIT = 0.02
LOOP_COMMAND_LAG_LIMIT = 3


@dataclass(frozen=True)
class LoopRun:
    """One closed-loop run and how well the host and the link kept its pace."""

    angles_deg: np.ndarray  # steps × fingers
    samples_skipped: int  # the firmware's samples the loop never stepped on
    worst_wait_periods: float  # the longest gap between two samples stepped on, in sample periods
    worst_command_lag: int  # the most commands sent and not yet held by the firmware at a sample

    def disturbance(self) -> str | None:
        """Why this run was not a loop at the firmware's pace, or None when it was."""
        steps = len(self.angles_deg)
        reasons = []
        if self.worst_wait_periods > LOOP_WAIT_LIMIT_PERIODS:
            reasons.append(f"a wait of {self.worst_wait_periods:.1f} sample periods")
        if self.samples_skipped > LOOP_SKIPPED_LIMIT * steps:
            reasons.append(f"{self.samples_skipped} of {steps + self.samples_skipped} samples skipped")
        if self.worst_command_lag > LOOP_COMMAND_LAG_LIMIT:
            reasons.append(f"commands {self.worst_command_lag} behind")
        return ", ".join(reasons) or None

    def summary(self) -> str:
        return (f"{self.samples_skipped} samples skipped, longest wait {self.worst_wait_periods:.1f} "
                f"periods, commands at most {self.worst_command_lag} behind")


def step_to_angle(transport: Any, profile: Profile, angle_ref_deg: float = 45.0,
                  seconds: float = 2.5) -> LoopRun:
    """Every finger in position mode to `angle_ref_deg` for `seconds` of control, one step on
    each fresh sample. A loaded host takes the newest sample after a wait, so it may need
    longer: five times `seconds`, at most."""
    hand = rtcore.Hand(profile.hand_config())
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    hand.inputs.angle_ref_deg[:] = angle_ref_deg
    period_s = 1.0 / profile.control.rate_hz
    angles = []
    skipped = 0
    worst_wait_s = 0.0
    worst_lag = 0
    previous = None
    steps = round(seconds * profile.control.rate_hz)
    end = time.monotonic() + 5 * seconds
    while len(angles) < steps and time.monotonic() < end:
        sample = transport.latest()
        if sample is None:
            time.sleep(0.001)
            continue
        if previous is not None:
            skipped += sample.sequence - previous.sequence - 1
            worst_wait_s = max(worst_wait_s, sample.received_s - previous.received_s)
            if sample.command_sequence >= 0:
                worst_lag = max(worst_lag, transport.command_sequence - sample.command_sequence)
        previous = sample
        hand.inputs.sensor_mv[:] = sample.sensor_mv
        hand.step()
        transport.send(hand.outputs.pressure_cmd_kpa)
        angles.append(hand.outputs.angle_deg.copy())
    assert len(angles) == steps, f"only {len(angles)} samples in {5 * seconds} s"
    return LoopRun(np.array(angles), skipped, worst_wait_s / period_s, worst_lag)
