"""Whether a recording can tell the truth's effect from what a lab's analysis must allow
besides it (the sensor's offset and slow drift, and for gravity and a cubic spring the other
of the two), judged on the truth's side, apart from diagnose.

A finger that bends one way only (0 to 70°, say) cannot tell a posture-dependent gravity
load from a stiffening spring: over 0 ≤ θ ≤ 1 rad, θ³ lies within 3 % (by energy) of a
combination of θ² (what 1 − cos θ is, there) and θ (what k absorbs). Both are torques of
the angle alone, so they differ in the response only by that remainder. The pair is told
apart where the finger also bends the other way (θ³ is odd, 1 − cos θ even), or where the
effect is large enough that the remainder itself stands above the noise.

A dry friction on a finger that only ever moves one way (a release, a vent) is a
constant torque while it moves, and stops the finger where it would have rested with a
shifted zero: the sensor's unknown offset absorbs it exactly (on a first-order finger).
A dead zone whose threshold the command never leaves is a constant torque too.

`distinct_visibility` measures what is left on the scale of concealment (the RMS over the
sensor's noise RMS): the effect's signature (the truth's angle less its plain finger's),
after k, B and N (within a lab's ±25 % knowledge of them), the sensor's offset and drift
and, for gravity and a cubic spring, the other of the two are fitted to it, linearised
about the truth's plain finger. Below the battery's observability bar (0.4), the case
cannot be scored as naming the effect; diagnose is then right to say the recording cannot
tell, or to name the truth.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy import signal

from tests.diagnose.truth.linear import DEG, LinearModel, discrete_tf, response_deg

NOMINAL_RELATIVE_WIDTH = 0.25  # how well a lab knows k, B and N (docs/diagnose.md: the prior)

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


def nuisance_columns(n: int) -> np.ndarray:
    """A lab sensor's offset and slow drift over the recording: a constant, a slope and a
    curvature (the truth's drift has a period of 90 s or more). A dry friction that only
    ever moves the finger one way is a constant torque, and a dead zone the command never
    leaves is one too: each shifts the angle as an offset would."""
    x = np.linspace(-1.0, 1.0, n)
    return np.column_stack((np.ones(n), x, 1.5 * x**2 - 0.5))


def distinct_visibility(effect: str, theta_deg: np.ndarray, command_kpa: np.ndarray, rate_hz: float,
                        plain_model: LinearModel, theta0_deg: float,
                        noise_rms_deg: float) -> tuple[str, float]:
    """(the competitor's name or '', what the truth's effect leaves over the noise RMS once
    k, B and N, the sensor's offset and drift and the competitor are fitted to it).

    The fit is linearised about `plain_model`, the truth's own plain finger (what a lab's
    nominal model is centred on): the effect's signature is the truth's angle less that
    model's; k, B and N enter by their sensitivities, held by the lab's ±25 % knowledge of
    them (rows of σ·Δln/0.25: a recording that pins only their ratios cannot slide them
    along the ratio to absorb an effect, and a slow valve that a free refit mimics by
    scaling all three stays visible); the nuisance and the competitor enter freely."""
    competitor, form = COMPETITORS.get(effect, ("", None))
    torques = [] if form is None else [form(np.asarray(theta_deg, dtype=float) * DEG)]
    return competitor, left_over(theta_deg, command_kpa, rate_hz, plain_model, theta0_deg, noise_rms_deg,
                                 torques)


def library_torques(theta_deg: np.ndarray, omega_rad_s: np.ndarray) -> list[np.ndarray]:
    """The shapes of the eight's torques that are functions of the finger's state, in the
    library's forms (docs/formats.md): a cubic spring θ³, gravity 1 − cos θ, dry friction
    sign θ' (tanh-smoothed at 0.01 rad/s), air drag |θ'|·θ', and the backward spring's
    extra θ·[θ < 0]. (The valve lag, dead time and dead zone act on the command.)"""
    theta = np.asarray(theta_deg, dtype=float) * DEG
    omega = np.asarray(omega_rad_s, dtype=float)
    return [theta**3, 1.0 - np.cos(theta), np.tanh(omega / 0.01), np.abs(omega) * omega,
            np.minimum(theta, 0.0)]


def left_over(theta_deg: np.ndarray, command_kpa: np.ndarray, rate_hz: float, plain_model: LinearModel,
              theta0_deg: float, noise_rms_deg: float, torques: list[np.ndarray]) -> float:
    """What the truth's effect leaves over the noise RMS once k, B and N (held by a lab's
    ±25 %), the sensor's offset and drift and each torque of `torques` (free, through the
    plain finger, linearised) are fitted to its signature (the truth's angle less its plain
    finger's)."""
    plain_deg = response_deg(plain_model, command_kpa, rate_hz, theta0_deg)
    signature = np.asarray(theta_deg, dtype=float) - plain_deg
    plain = plain_sensitivities(plain_model, command_kpa, rate_hz, theta0_deg)
    columns = [plain, nuisance_columns(len(signature))]
    columns += [torque_response_rad(plain_model, torque, rate_hz)[:, None] / DEG for torque in torques]
    stacked = np.column_stack(columns)
    prior = np.zeros((plain.shape[1], stacked.shape[1]))
    prior[:, : plain.shape[1]] = np.eye(plain.shape[1]) * noise_rms_deg / NOMINAL_RELATIVE_WIDTH
    target = np.concatenate((signature, np.zeros(plain.shape[1])))
    coeffs, *_ = np.linalg.lstsq(np.vstack((stacked, prior)), target, rcond=None)
    left = signature - stacked @ coeffs
    return float(np.sqrt(np.mean(left**2)) / noise_rms_deg)
