"""The C control step driven through a transport at the firmware's pace: the closed-loop
step the HIL suite runs against the mock, the host build and the QEMU image alike."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

import rtcore
from hand_service.config.profile import Profile


def step_to_angle(transport: Any, profile: Profile, angle_ref_deg: float = 45.0,
                  seconds: float = 2.5) -> np.ndarray:
    """Every finger in position mode to `angle_ref_deg` for `seconds` of control, one step on
    each fresh sample; the angles (steps × fingers). A loaded host takes the newest sample
    after a wait, so it may need longer: five times `seconds`, at most."""
    hand = rtcore.Hand(profile.hand_config())
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    hand.inputs.angle_ref_deg[:] = angle_ref_deg
    angles = []
    steps = round(seconds * profile.control.rate_hz)
    end = time.monotonic() + 5 * seconds
    while len(angles) < steps and time.monotonic() < end:
        sample = transport.latest()
        if sample is None:
            time.sleep(0.001)
            continue
        hand.inputs.sensor_mv[:] = sample.sensor_mv
        hand.step()
        transport.send(hand.outputs.pressure_cmd_kpa)
        angles.append(hand.outputs.angle_deg.copy())
    assert len(angles) == steps, f"only {len(angles)} samples in {5 * seconds} s"
    return np.array(angles)
