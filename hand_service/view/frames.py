"""Ring rows -> the page's frames: per finger the signals it plots, as JSON.

A ring row (hand_service/service/recorder_writer.py) is t_s, state, then for each
quantity of QUANTITIES one column per finger. A frame carries every row pushed since the
last frame, thinned to at most MAX_PLOT_HZ rows per second (rows whose index is a
multiple of the step, so frames join without a seam), with each value rounded for the
wire and every non-finite value as null (a gap in the plot). A reference is sent only
under its mode (angle_ref_deg in position mode, force_ref_n in force mode), as the CSV
writes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hand_service.service.recorder_writer import HEAD, QUANTITIES, STATE_NAMES
from rtcore.config import MODE_FORCE, MODE_POSITION

MAX_PLOT_HZ = 200.0  # rows per second sent to the page, at most
DIGITS = 3

# what the page plots, per finger: wire name -> the ring's quantity
SIGNALS: dict[str, str] = {
    "angle_ref_deg": "angle_ref_deg",
    "angle_deg": "angle_deg",  # measured (calibrated, unfiltered)
    "angle_filt_deg": "angle_filt_deg",
    "angle_true_deg": "angle_true_deg",  # the simulated hand's truth; null from a board
    "pressure_cmd_kpa": "pressure_kpa",
    "pressure_meas_kpa": "pressure_meas_kpa",
    "force_est_n": "force_est_n",
    "force_ref_n": "force_ref_n",
}


def state_name(code: float) -> str:
    return STATE_NAMES[int(code)] if math.isfinite(code) and 0 <= code < len(STATE_NAMES) else "?"


def wire_values(values: np.ndarray) -> list[float | None]:
    """Rounded, with null for NaN and the infinities (JSON has neither)."""
    rounded = np.round(values.astype(float), DIGITS)
    return [float(v) if math.isfinite(v) else None for v in rounded.tolist()]


@dataclass
class FrameMaker:
    """Rows of a ring for `fingers` -> the signal part of a frame."""

    fingers: list[str]
    rate_hz: float

    def __post_init__(self) -> None:
        n = len(self.fingers)
        self.n_cols = len(HEAD) + len(QUANTITIES) * n
        self.step = max(1, math.ceil(self.rate_hz / MAX_PLOT_HZ))
        self._column = {q: len(HEAD) + i * n for i, q in enumerate(QUANTITIES)}

    def signals(self, rows: np.ndarray, first: int) -> dict[str, object]:
        """{"t_s": [...], "state": last state name or None, "fingers": {name: {signal: [...]}}}
        for the rows from index `first`."""
        if rows.shape[1] != self.n_cols:
            raise ValueError(f"a ring of {rows.shape[1]} columns does not hold the fingers "
                             f"{', '.join(self.fingers)} ({self.n_cols} columns)")
        index = np.arange(first, first + rows.shape[0])
        kept = rows[index % self.step == 0]
        fingers: dict[str, dict[str, list[float | None]]] = {}
        for f, name in enumerate(self.fingers):
            mode = kept[:, self._column["mode"] + f]
            signals = {}
            for wire, quantity in SIGNALS.items():
                values = kept[:, self._column[quantity] + f].copy()
                if quantity == "angle_ref_deg":
                    values[mode != MODE_POSITION] = np.nan
                elif quantity == "force_ref_n":
                    values[mode != MODE_FORCE] = np.nan
                signals[wire] = wire_values(values)
            fingers[name] = signals
        return {"t_s": wire_values(kept[:, 0]),
                "state": state_name(float(rows[-1, 1])) if rows.shape[0] else None,
                "fingers": fingers}


__all__ = ["MAX_PLOT_HZ", "SIGNALS", "FrameMaker", "state_name", "wire_values"]
