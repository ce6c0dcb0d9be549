"""Latency of one control step for the whole hand: the C core through cffi, and the
pure-Python reference, measured call by call in the same run."""

from __future__ import annotations

import gc
import math
import time
from dataclasses import dataclass

import numpy as np

import rtcore


@dataclass
class StepTimes:
    c_step_ns: np.ndarray
    python_step_ns: np.ndarray
    timer_overhead_ns: float
    fingers: int

    def summary(self) -> dict[str, float | int]:
        c50, c99 = np.percentile(self.c_step_ns, [50, 99])
        p50, p99 = np.percentile(self.python_step_ns, [50, 99])
        return {"c_step_ns_p50": float(c50), "c_step_ns_p99": float(c99),
                "python_step_ns_p50": float(p50), "python_step_ns_p99": float(p99),
                "python_over_c": float(p50 / c50), "timer_overhead_ns": self.timer_overhead_ns,
                "fingers": self.fingers}


def _drive(hand: rtcore.Hand | rtcore.ReferenceHand, config: rtcore.HandConfig, calls: int) -> np.ndarray:
    """Time `calls` steps in position mode on a moving sensor signal, one by one."""
    inputs = hand.inputs
    inputs.mode[:] = rtcore.MODE_POSITION
    gains = np.array([f.sensor_gain_deg_per_mv for f in config.fingers])
    offsets = np.array([f.sensor_offset_deg for f in config.fingers])
    angles = 45.0 * (1.0 - np.cos(2 * math.pi * np.arange(calls) / (0.75 * config.sample_rate_hz)))
    times = np.empty(calls, dtype=np.int64)
    clock = time.perf_counter_ns
    step = hand.step
    sensor, ref = inputs.sensor_mv, inputs.angle_ref_deg
    for k in range(calls):
        sensor[:] = (angles[k] + 0.5 - offsets) / gains
        ref[:] = angles[k]
        t0 = clock()
        step()
        times[k] = clock() - t0
    return times


def measure(config: rtcore.HandConfig, c_calls: int, python_calls: int) -> StepTimes:
    clock = time.perf_counter_ns
    gc.collect()
    gc.disable()
    try:
        overhead = np.empty(10000, dtype=np.int64)
        for k in range(overhead.size):
            t0 = clock()
            overhead[k] = clock() - t0
        c_times = _drive(rtcore.Hand(config), config, c_calls)
        py_times = _drive(rtcore.ReferenceHand(config), config, python_calls)
    finally:
        gc.enable()
    return StepTimes(c_times, py_times, float(np.median(overhead)), config.n_fingers)
