"""Recordings onto one uniform time base.

A daemon on a loaded PC now and then skips a deadline: its recording then lacks a row
(t jumps by two periods) while the valves held the last command through the gap. Such a
recording is put back on its uniform grid: the command is held through the missing
samples (what the valves did), the angle is interpolated there only to keep the residual
statistics defined, and `missing` marks those samples so that no fit and no score uses
them. Small timing jitter is absorbed by rounding each time to its nearest slot.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_service.errors import UserError

MAX_MISSING_FRACTION = 0.1
MAX_STEP_OFF_PERIODS = 0.45  # each step is a whole number of periods, give or take jitter


@dataclass(frozen=True)
class Grid:
    t_s: np.ndarray
    pressure_kpa: np.ndarray
    angle_deg: np.ndarray
    missing: np.ndarray  # True where the recording had no row
    rate_hz: float

    @property
    def n_missing(self) -> int:
        return int(self.missing.sum())


def regular_grid(t_s: np.ndarray, pressure_kpa: np.ndarray, angle_deg: np.ndarray,
                 path: str | Path) -> Grid:
    dt = np.diff(t_s)
    nominal = float(np.median(dt))
    steps = dt / nominal
    whole = np.rint(steps)
    off = np.abs(steps - whole)
    if np.any(whole < 1) or off.max() > MAX_STEP_OFF_PERIODS:
        worst = int(np.argmax(off + (whole < 1)))
        raise UserError(f"{path}: the samples are not on one rate: t steps by {dt[worst]:.4g} s after "
                        f"t = {t_s[worst]:.4g} s where the period is {nominal:.4g} s (small jitter and "
                        "whole skipped samples are fine)")
    slots = np.concatenate([[0], np.cumsum(whole.astype(np.int64))])
    n = int(slots[-1]) + 1
    missing_count = n - slots.size
    if missing_count > MAX_MISSING_FRACTION * n:
        raise UserError(f"{path}: {missing_count} of {n} samples are missing (more than "
                        f"{MAX_MISSING_FRACTION:.0%}); diagnose needs a nearly complete recording")
    period, start_s = np.polyfit(slots, t_s, 1)  # least squares: unbiased under jitter
    grid = np.arange(n)
    held_row = np.searchsorted(slots, grid, side="right") - 1  # the last row at or before each slot
    missing = np.ones(n, dtype=bool)
    missing[slots] = False
    return Grid(start_s + grid * period, pressure_kpa[held_row], np.interp(grid, slots, angle_deg),
                missing, 1.0 / float(period))
