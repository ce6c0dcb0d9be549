"""Position tracking in closed loop (Table 2 of the paper): the C control step drives the
simulated hand, every finger at once, and the error is the TRUE angle against the
reference. And the tuning of PID alone, so that it gets its best shot.

PID alone is tuned per finger by minimising its own tracking RMSE on the very task it
is judged on (the cosine sweep, first period left out), in closed loop with the
simulated hand. The score of a candidate is its worst RMSE over two runs with other
sensor-noise seeds than the evaluation's, each twice as long as the test: gains that
only look good until a slowly growing oscillation shows, or for one noise draw, are not
a PID anyone would keep (found on the ring finger: 8.5° on one seed, 14° on another).

1. a log-spaced grid over kp × ki × kd, all fingers at once;
2. from each finger's three best grid points, a compass search in log space over kp,
   ki, kd and the derivative filter's cutoff: each parameter ×/÷ a step, kept when it
   lowers the RMSE, the step halved when nothing does, until it is below 2 %; the best
   of the three searches wins.

PID alone has no feedforward, so its integrator may hold the whole pressure: its limit
is the finger's pressure limit (the profile's 50 kPa would cripple it). Everything else
(filters, saturation, rate limit, anti-windup) is the same as for FF+PID.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

import rtcore
from hand_service.service.trajectory import CosineSweep
from hand_service.simulator import Simulator

TUNED = ("kp_kpa_per_deg", "ki_kpa_per_deg_s", "kd_kpa_s_per_deg", "derivative_cutoff_hz")
KP_GRID = (0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 2.5, 4.0)
KI_GRID = (0.5, 1.5, 4.0, 10.0, 25.0, 60.0)
KD_GRID = (0.0, 0.005, 0.015, 0.04)
CUTOFF_RANGE_HZ = (1.0, 45.0)
TUNING_LENGTH = 2  # tuning runs are this many times the test's length
STARTS = 3  # compass searches, from the grid's best, second and third point of each finger


@dataclass
class TrackingRun:
    fingers: list[str]
    t_s: np.ndarray
    reference_deg: np.ndarray
    angle_deg: np.ndarray  # true angle, (ticks, fingers)
    command_kpa: np.ndarray
    skip_ticks: int  # the first period, left out of the figures

    @property
    def error_deg(self) -> np.ndarray:
        return self.angle_deg[self.skip_ticks:] - self.reference_deg[self.skip_ticks:, None]

    @property
    def rmse_deg(self) -> np.ndarray:
        return np.sqrt(np.mean(self.error_deg**2, axis=0))

    @property
    def max_error_deg(self) -> np.ndarray:
        return np.max(np.abs(self.error_deg), axis=0)


def track(config: rtcore.HandConfig, make_sim: Callable[[int], Simulator], seed: int, periods: int = 10,
          sweep: CosineSweep | None = None) -> TrackingRun:
    """Track the sweep with every finger; `make_sim(seed)` builds the simulated hand."""
    sweep = sweep or CosineSweep()
    hand = rtcore.Hand(config)
    sim = make_sim(seed)
    rate = config.sample_rate_hz
    n = round(periods * sweep.period_s * rate)
    t = np.arange(n) / rate
    refs = sweep.at(t)
    angle = np.empty((n, config.n_fingers))
    command = np.empty((n, config.n_fingers))
    inputs, outputs = hand.inputs, hand.outputs
    inputs.mode[:] = rtcore.MODE_POSITION
    for k in range(n):
        inputs.sensor_mv[:] = sim.outputs.sensor_mv
        inputs.angle_ref_deg[:] = refs.angle_deg[k]
        inputs.velocity_ref_deg_per_s[:] = refs.velocity_deg_per_s[k]
        inputs.accel_ref_deg_per_s2[:] = refs.accel_deg_per_s2[k]
        inputs.jerk_ref_deg_per_s3[:] = refs.jerk_deg_per_s3[k]
        hand.step()
        angle[k] = sim.outputs.angle_deg
        command[k] = outputs.pressure_cmd_kpa
        sim.command_kpa[:] = outputs.pressure_cmd_kpa
        sim.step()
    return TrackingRun([str(i) for i in range(config.n_fingers)], t, refs.angle_deg, angle, command,
                       round(sweep.period_s * rate))


def pid_alone(config: rtcore.HandConfig) -> rtcore.HandConfig:
    """The same controller without feedforward; the integrator may hold the whole pressure."""
    return rtcore.HandConfig([f.replace(feedforward=rtcore.FF_NONE, integrator_limit_kpa=f.pressure_max_kpa)
                              for f in config.fingers], config.sample_rate_hz)


def with_gains(config: rtcore.HandConfig, gains: np.ndarray) -> rtcore.HandConfig:
    """gains: (fingers, len(TUNED))."""
    return rtcore.HandConfig([f.replace(**dict(zip(TUNED, map(float, g), strict=True)))
                              for f, g in zip(config.fingers, gains, strict=True)], config.sample_rate_hz)


@dataclass
class Tuning:
    gains: np.ndarray  # (fingers, len(TUNED)), the best found
    rmse_deg: np.ndarray  # each finger's tuning RMSE at those gains
    evaluations: int
    history: list[np.ndarray] = field(default_factory=list)  # best RMSE per finger after each stage

    def gains_of(self, finger: int) -> dict[str, float]:
        return dict(zip(TUNED, map(float, self.gains[finger]), strict=True))


def _compass(start: np.ndarray, rmse: Callable[[np.ndarray], np.ndarray], step: float,
             lowest: float) -> tuple[np.ndarray, np.ndarray]:
    """Compass search in log space, every finger at once (each keeps its own best)."""
    best, best_rmse = start.copy(), rmse(start)
    while step >= lowest:
        improved = np.zeros(best.shape[0], dtype=bool)
        for j in range(len(TUNED)):
            for direction in (1.0, -1.0):
                candidate = best.copy()
                candidate[:, j] *= math.exp(direction * step)
                candidate[:, 3] = np.clip(candidate[:, 3], *CUTOFF_RANGE_HZ)
                score = rmse(candidate)
                better = score < best_rmse - 1e-6
                best[better], best_rmse[better] = candidate[better], score[better]
                improved |= better
        if not improved.any():
            step /= 2.0
    return best, best_rmse


def tune_pid(config: rtcore.HandConfig, make_sim: Callable[[int], Simulator], seed: int, periods: int = 10,
             quick: bool = False, progress: Callable[[str], None] | None = None) -> Tuning:
    """Each finger's PID-alone gains that minimise its tracking RMSE (module docstring).
    Quick: a coarser grid, one search, one seed."""
    base = pid_alone(config)
    n = config.n_fingers
    evaluations = 0
    seeds = (seed,) if quick else (seed, seed + 1)

    def rmse(gains: np.ndarray) -> np.ndarray:
        nonlocal evaluations
        evaluations += 1
        tuned = with_gains(base, gains)
        result = np.max([track(tuned, make_sim, s, TUNING_LENGTH * periods).rmse_deg for s in seeds], axis=0)
        return np.where(np.isfinite(result), result, np.inf)

    cutoffs = np.array([f.derivative_cutoff_hz for f in config.fingers])
    axes = (KP_GRID[1::2], KI_GRID[::2], KD_GRID[::2]) if quick else (KP_GRID, KI_GRID, KD_GRID)
    grid = np.array(list(itertools.product(*axes)))
    scores = np.empty((len(grid), n))
    for i, (kp, ki, kd) in enumerate(grid):
        scores[i] = rmse(np.column_stack([np.full(n, kp), np.full(n, ki), np.full(n, kd), cutoffs]))
        if progress and (i + 1) % 24 == 0:
            so_far = np.round(scores[:i + 1].min(axis=0), 2).tolist()
            progress(f"PID grid {i + 1}/{len(grid)}: best RMSE {so_far} deg")
    history = [scores.min(axis=0)]
    best = np.zeros((n, len(TUNED)))
    best_rmse = np.full(n, np.inf)
    for rank in range(1 if quick else STARTS):
        start = np.column_stack([grid[np.argsort(scores, axis=0)[rank]], cutoffs])
        start[:, 2] = np.maximum(start[:, 2], 1e-3)  # the search moves in log space: kd off zero
        found, found_rmse = _compass(start, rmse, 0.5 if quick else 0.35, 0.1 if quick else 0.02)
        better = found_rmse < best_rmse
        best[better], best_rmse[better] = found[better], found_rmse[better]
        history.append(best_rmse.copy())
        if progress:
            progress(f"PID search from the grid's #{rank + 1} point: "
                     f"best RMSE {np.round(best_rmse, 2).tolist()} deg")
    return Tuning(best, best_rmse, evaluations, history)


__all__ = ["KD_GRID", "KI_GRID", "KP_GRID", "TUNED", "TrackingRun", "Tuning", "pid_alone", "track",
           "tune_pid", "with_gains"]
