"""The demo `make run` shows: the simulated hand tracks the paper's sweep on every
finger, with the C control step in closed loop, then reports tracking and timing."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

import rtcore
from hand_service.profile import Profile
from hand_service.simulator import hand_simulator
from hand_service.trajectory import CosineSweep


@dataclass
class DemoResult:
    fingers: list[str]
    rmse_deg: np.ndarray
    max_error_deg: np.ndarray
    step_ns_p50: float
    step_ns_p99: float
    ticks: int


def track_sweep(profile: Profile, periods: int = 8, sweep: CosineSweep | None = None,
                progress: bool = False) -> DemoResult:
    """Closed loop: sensor -> C step -> valves, the first period left out of the figures."""
    sweep = sweep or CosineSweep()
    config = profile.hand_config()
    hand = rtcore.Hand(config)
    sim = hand_simulator(profile)
    rate = config.sample_rate_hz
    n = round(periods * sweep.period_s * rate)
    refs = sweep.at(np.arange(n) / rate)
    errors = np.empty((n, config.n_fingers))
    step_ns = np.empty(n, dtype=np.int64)
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    clock = time.perf_counter_ns
    for k in range(n):
        hand.inputs.sensor_mv[:] = sim.outputs.sensor_mv
        hand.inputs.angle_ref_deg[:] = refs.angle_deg[k]
        hand.inputs.velocity_ref_deg_per_s[:] = refs.velocity_deg_per_s[k]
        hand.inputs.accel_ref_deg_per_s2[:] = refs.accel_deg_per_s2[k]
        hand.inputs.jerk_ref_deg_per_s3[:] = refs.jerk_deg_per_s3[k]
        t0 = clock()
        hand.step()
        step_ns[k] = clock() - t0
        errors[k] = sim.outputs.angle_deg - refs.angle_deg[k]
        sim.command_kpa[:] = hand.outputs.pressure_cmd_kpa
        sim.step()
        if progress and k % int(rate) == 0:
            rms = np.sqrt(np.mean(errors[max(0, k - int(rate)):k + 1] ** 2))
            print(f"\r  t = {k / rate:5.1f} s   tracking error (last 1 s) {rms:5.2f} deg", end="", flush=True)
    if progress:
        print()
    kept = errors[round(sweep.period_s * rate):]
    return DemoResult([f.name for f in profile.fingers], np.sqrt(np.mean(kept**2, axis=0)),
                      np.max(np.abs(kept), axis=0), float(np.percentile(step_ns, 50)),
                      float(np.percentile(step_ns, 99)), n)
