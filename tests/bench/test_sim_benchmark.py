"""Wall time of one noise-free simulation (rtcore_sim_run), the unit a fit repeats hundreds
of times (`make bench`; in `make test` each case runs once, as a smoke test).

The cases of the over-damped soft actuator (B/A = 5000/s, no resonance) over a 2-minute
25 Hz recording, and of the paper's index finger at 0.25 Hz, 100 Hz and 1 kHz for 30 s,
each with at least a step per sample (substeps = 1), with the steps left to the dynamics
over the held levels (substeps = 0, what hand_service/diagnose asks: csrc/rtcore_sim_span.c)
and capped at 1 ms. Compare the cases as ratios within one run; the step counts behind them
are in csrc/rtcore_sim_step_size.c (rtcore_sim_parameter_step_s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtcore import Effects, Prbm
from rtcore.sim import SimFinger, simulate

OVERDAMPED = Prbm(inertia_kgm2=1e-5, damping_nms_per_rad=0.05, stiffness_nm_per_rad=0.5,
                  pressure_gain_nm_per_kpa=0.01, lever_arm_m=0.04)
PAPER = Prbm(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
             pressure_gain_nm_per_kpa=0.0119, lever_arm_m=0.04)
CASES = {
    "overdamped-25Hz-120s": (OVERDAMPED, 25.0, 120.0),
    "paper-0.25Hz-30s": (PAPER, 0.25, 30.0),
    "paper-100Hz-30s": (PAPER, 100.0, 30.0),
    "paper-1kHz-30s": (PAPER, 1000.0, 30.0),
}


def steps_of_1_ms(rate_hz: float) -> int:
    return max(1, math.ceil(1.0 / (rate_hz * 1e-3) - 1e-9))


def commands(rate_hz: float, seconds: float) -> np.ndarray:
    """Levels of 0-120 kPa held 0.5 s each (one sample each below 2 Hz)."""
    n = int(seconds * rate_hz) + 1
    hold = max(1, int(0.5 * rate_hz))
    return np.repeat(np.random.default_rng(0).uniform(0.0, 120.0, n // hold + 2), hold)[:n]


@pytest.mark.parametrize("substeps", ["free", "spans", "1ms"])
@pytest.mark.parametrize("effects", ["plain", "lag+friction"])
@pytest.mark.parametrize("case", list(CASES))
def test_one_simulation(benchmark, case: str, effects: str, substeps: str) -> None:
    prbm, rate_hz, seconds = CASES[case]
    if effects != "plain":
        prbm = Prbm(**{**prbm.__dict__, "effects": Effects(valve_lag_tau_s=0.03, coulomb_torque_nm=0.002)})
    finger = SimFinger(prbm)
    command = commands(rate_hz, seconds)
    n = {"free": 1, "spans": 0}.get(substeps) if substeps != "1ms" else steps_of_1_ms(rate_hz)
    angle, _ = benchmark(simulate, finger, command, rate_hz, n)
    assert np.all(np.isfinite(angle))
