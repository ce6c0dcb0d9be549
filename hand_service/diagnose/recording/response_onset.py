"""When the recorded finger starts to answer a step of the command, measured from the data
alone: what a sentence about a delay is checked against.

At each clear step of the command (at least STEP_SHARE of the command's range, the command
held before it and for a while after), taken from a finger at rest (its angle still over
the hold before the step), the onset is the first sample at which the angle leaves the band
of its rest by ONSET_NOISE times the sensor's white noise. The delay is the median over the
steps, in seconds; None where the command has no such step (a chirp, a ramp).
"""

from __future__ import annotations

import numpy as np

STEP_SHARE = 0.2  # a clear step: this share of the command's range at once
HOLD_S = 0.1  # the command held this long before the step, and the finger still
SEARCH_S = 1.0  # the onset looked for this long after the step (or up to the next change)
ONSET_NOISE = 5.0  # leaving the rest band by this many times the white noise


def white_noise_deg(angle_deg: np.ndarray) -> float:
    """The sensor's white noise from the data alone: the robust spread of the sample-to-sample
    differences (a smooth motion adds little to them), over √2."""
    d = np.diff(angle_deg)
    if d.size == 0:
        return 0.0
    return float(np.median(np.abs(d - np.median(d))) / 0.6745 / np.sqrt(2.0))


def onset_delay_s(command_kpa: np.ndarray, angle_deg: np.ndarray, rate_hz: float) -> float | None:
    """The median delay from a clear step of the command to the recorded response's onset."""
    command = np.asarray(command_kpa, dtype=float)
    angle = np.asarray(angle_deg, dtype=float)
    span = float(np.ptp(command))
    if span <= 0.0:
        return None
    hold = max(3, round(HOLD_S * rate_hz))
    search = max(3, round(SEARCH_S * rate_hz))
    noise = white_noise_deg(angle)
    change = np.abs(np.diff(command))
    steps = np.flatnonzero(change >= STEP_SHARE * span) + 1
    moved_at = np.flatnonzero(change > 1e-9 * span) + 1  # every change of the command
    delays = []
    for i in steps:
        if i < hold or np.ptp(command[i - hold: i]) > 0.01 * span:
            continue
        before = angle[i - hold: i]
        if np.ptp(before) > 2.0 * ONSET_NOISE * noise:
            continue  # the finger was still moving: no rest to leave
        later = moved_at[moved_at > i]
        stop = min(i + search, int(later[0]) if later.size else angle.size, angle.size)
        band = ONSET_NOISE * noise + 0.5 * np.ptp(before)
        left = np.flatnonzero(np.abs(angle[i:stop] - before.mean()) > band)
        if left.size:
            delays.append(left[0] / rate_hz)
    return float(np.median(delays)) if delays else None


def delay_seen(delay_s: float, onset_s: float | None, rate_hz: float) -> bool:
    """Is a delay of `delay_s` beyond the model's seen in the recording, whose response
    starts `onset_s` after the command's steps? At least half of it must be there (two
    samples' grace); a recording without clear steps cannot say (True)."""
    return onset_s is None or onset_s + 2.0 / rate_hz >= 0.5 * delay_s
