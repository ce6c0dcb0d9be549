"""One sample period of a finger's linear PRBM, exact, for the model check (plausibility.py).

A θ'' + B θ' + k θ = N p between two board samples: the chamber p moves from its first
measurement to its second as the model's valve lag moves it (a first-order approach to the
constant input that makes it end there; a straight line where the model has no lag). The
same step carries the sensitivities s_k = ∂θ/∂ln k and s_B = ∂θ/∂ln B, driven by the
torques −k·θ and −B·θ', and their sum with θ (= −s_A), so that one matrix product per
finger moves all of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm, solve_discrete_lyapunov

from hand_service.config.effects import effect_value
from hand_service.config.model import FingerModel

# the state's columns: θ, s_k, s_B, Σ = θ + s_k + s_B, then their rates; the chamber [p0, p1]
# follows them in the model check's array
THETA, SUM, OMEGA = 0, 3, 4
STATE = 7


@dataclass(frozen=True)
class Step:
    """One sample period of a finger, exact: [θ, θ'] ← phi·[θ, θ'], + p0_gain·p0 + p1_gain·p1 for
    the chamber going from p0 to p1, + start_gain·τ0 + end_gain·τ1 for a torque going linearly
    from τ0 to τ1."""

    phi: np.ndarray  # 2×2
    p0_gain: np.ndarray  # 2
    p1_gain: np.ndarray  # 2
    start_gain: np.ndarray  # 2
    end_gain: np.ndarray  # 2
    alpha: float  # how much of the way from p0 the chamber stays after one period (e^(−dt/τ))

    def noise_rad(self, angle_noise_rad: float, pressure_noise_kpa: float) -> float:
        """One standard deviation of the innovation's noise (rad): the sensor's own, and the
        prediction's answer to white noise on each pressure reading, which enters a step as
        p1 and the next one as p0 (the stationary variance of that moving average through
        the finger: a discrete Lyapunov equation)."""
        a = np.zeros((3, 3))
        a[:2, :2], a[:2, 2] = self.phi, self.p0_gain
        b = np.append(self.p1_gain, 1.0)[:, None]
        prediction = solve_discrete_lyapunov(a, b @ b.T * pressure_noise_kpa**2)[0, 0]
        return math.sqrt(angle_noise_rad**2 + prediction)

    def state_map(self, stiffness: float, damping: float) -> np.ndarray:
        """The map of the state [θ, s_k, s_B, Σ, θ', s_k', s_B'] (STATE) and the chamber [p0, p1]
        to that state one period on, Σ = θ + s_k + s_B. s_k is driven by the torque −k·θ, s_B
        by −B·θ', each taken as a straight line from its value at the start to the end."""
        phi = self.phi
        m = np.zeros((STATE, STATE + 2))
        for row, at in ((0, THETA), (1, OMEGA)):  # the prediction
            m[at, (THETA, OMEGA)] = phi[row]
            m[at, STATE:] = self.p0_gain[row], self.p1_gain[row]
        for row, base in ((0, 0), (1, OMEGA)):
            for offset, gain, driver in ((1, -stiffness, THETA), (2, -damping, OMEGA)):
                at = base + offset  # s_k (or s_k') by θ, s_B (or s_B') by θ'
                m[at, (offset, OMEGA + offset)] = phi[row]
                m[at, driver] += gain * self.start_gain[row]
                m[at] += gain * self.end_gain[row] * m[driver]
        m[SUM] = m[THETA] + m[1] + m[2]
        return m


def discretize(model: FingerModel, dt_s: float) -> Step:
    """The exact step of the finger's linear PRBM over dt_s, the chamber between its two
    samples following the valve's first-order lag toward a constant input (the input that
    makes it end where it was measured), or a straight line where the model has no lag."""
    a, b, k = model.inertia_kgm2, model.damping_nms_per_rad, model.stiffness_nm_per_rad
    n_gain = model.pressure_gain_nm_per_kpa
    tau = effect_value(model.effects, "valve_lag")
    m = np.zeros((4, 4))
    m[0, 1] = 1.0
    m[1, :2] = (-k / a, -b / a)  # type: ignore[operator]
    ramp = m.copy()  # state [θ, θ', τ, r]: τ' = r = (τ1 − τ0)/dt, held
    ramp[1, 2], ramp[2, 3] = 1.0 / a, 1.0
    e = expm(ramp * dt_s)
    start_gain, end_gain = e[:2, 2] - e[:2, 3] / dt_s, e[:2, 3] / dt_s
    if tau <= 0.0:  # the chamber a straight line: N·p a torque ramp
        return Step(e[:2, :2], n_gain * start_gain, n_gain * end_gain, start_gain, end_gain, 0.0)
    m[1, 2] = n_gain / a  # type: ignore[operator]
    m[2, 2:] = (-1.0 / tau, 1.0 / tau)  # state [θ, θ', p, c]: p' = (c − p)/τ, c held
    e = expm(m * dt_s)
    alpha = math.exp(-dt_s / tau)
    per_c = e[:2, 3] / (1.0 - alpha)  # p1 = c + (p0 − c)·α, so c = (p1 − α·p0) / (1 − α)
    return Step(e[:2, :2], e[:2, 2] - alpha * per_c, per_c, start_gain, end_gain, alpha)
