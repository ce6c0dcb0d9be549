"""Whether a recording can tell the truth's effect from a second library effect, judged on
the truth's side, apart from diagnose.

A finger that bends one way only (0 to 70°, say) cannot tell a posture-dependent gravity
load from a stiffening spring: over 0 ≤ θ ≤ 1 rad, θ³ lies within 3 % (by energy) of a
combination of θ² (what 1 − cos θ is, there) and θ (what k absorbs). Both are torques of
the angle alone, so they differ in the response only by that remainder. The pair is told
apart where the finger also bends the other way (θ³ is odd, 1 − cos θ even), or where the
effect is large enough that the remainder itself stands above the noise.

`distinct_visibility` measures the remainder as the battery measures concealment: the
residual RMS that the best plain linear model leaves (cases._visibility), after the
competitor's torque and the plain parameters are fitted to it as well (linearised around
that refit: the linear finger's response to the competitor's torque along the true
trajectory, and the sensitivities to k, B and N), over the sensor's noise RMS. Below the
battery's observability bar (0.4), the case cannot be scored as naming one of the two;
diagnose is then right to say the recording cannot tell them apart, or to name the truth.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy import signal

from tests.diagnose.truth.linear import DEG, LinearModel, discrete_tf, response_deg

# the competitor of each effect, in the library's own form (docs/formats.md): a torque of θ (rad)
COMPETITORS: dict[str, tuple[str, Callable[[np.ndarray], np.ndarray]]] = {
    "gravity": ("cubic_stiffness", lambda theta: theta**3),
    "cubic_stiffness": ("gravity", lambda theta: 1.0 - np.cos(theta)),
}


def torque_response_rad(model: LinearModel, torque_nm: np.ndarray, rate_hz: float) -> np.ndarray:
    """The linear finger's angle (rad) under an extra torque held between samples, from rest."""
    mech = LinearModel(model.inertia_kgm2, model.damping_nms_per_rad, model.stiffness_nm_per_rad, 1.0)
    num, den, _ = discrete_tf(mech, rate_hz)
    return signal.lfilter(num, den, torque_nm - torque_nm[0])


def plain_sensitivities(model: LinearModel, command_kpa: np.ndarray, rate_hz: float,
                        theta0_deg: float) -> np.ndarray:
    """d(angle)/d(ln k, ln B, ln N), by central differences of the exact response (deg)."""
    cols = []
    for name in ("stiffness_nm_per_rad", "damping_nms_per_rad", "gain_nm_per_kpa"):
        value = getattr(model, name)
        up = response_deg(replace(model, **{name: value * 1.001}), command_kpa, rate_hz, theta0_deg)
        down = response_deg(replace(model, **{name: value / 1.001}), command_kpa, rate_hz, theta0_deg)
        cols.append((up - down) / (2.0 * np.log(1.001)))
    return np.column_stack(cols)


def distinct_visibility(effect: str, theta_deg: np.ndarray, command_kpa: np.ndarray, rate_hz: float,
                        fitted: LinearModel, residual_deg: np.ndarray, theta0_deg: float,
                        noise_rms_deg: float) -> tuple[str, float]:
    """(competitor, what the truth's effect leaves above the plain model and the competitor
    together, over the noise RMS); ('', inf) for an effect without a competitor."""
    if effect not in COMPETITORS:
        return "", float("inf")
    competitor, form = COMPETITORS[effect]
    theta_rad = np.asarray(theta_deg, dtype=float) * DEG
    columns = np.column_stack((plain_sensitivities(fitted, command_kpa, rate_hz, theta0_deg),
                               torque_response_rad(fitted, form(theta_rad), rate_hz) / DEG))
    scale = np.sqrt(np.sum(columns**2, axis=0))
    scale[scale == 0.0] = 1.0
    coeffs, *_ = np.linalg.lstsq(columns / scale, residual_deg, rcond=None)
    left = residual_deg - (columns / scale) @ coeffs
    return competitor, float(np.sqrt(np.mean(left**2)) / noise_rms_deg)
