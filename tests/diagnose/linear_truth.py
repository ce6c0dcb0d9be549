"""A plain PRBM finger simulated apart from the project's simulator: the linear ODE
A θ'' + B θ' + k θ = N p, discretised exactly under a command held between samples
(scipy.signal.cont2discrete, zero-order hold). Used to test diagnose on recordings its own
simulator did not make."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class LinearFinger:
    inertia_kgm2: float = 1.6e-4
    damping_nms_per_rad: float = 0.003
    stiffness_nm_per_rad: float = 0.57
    pressure_gain_nm_per_kpa: float = 0.0119

    def model_yaml(self) -> str:
        """The paper's minimal model: A, B, k and N, nothing else."""
        return (f"inertia_kgm2: {self.inertia_kgm2}\ndamping_nms_per_rad: {self.damping_nms_per_rad}\n"
                f"stiffness_nm_per_rad: {self.stiffness_nm_per_rad}\n"
                f"pressure_gain_nm_per_kpa: {self.pressure_gain_nm_per_kpa}\n")

    def angle_deg(self, pressure_kpa: np.ndarray, rate_hz: float) -> np.ndarray:
        """The angle at every sample from rest at 0; angle[k + 1] follows command k held for
        one period."""
        a, b, k, n = (self.inertia_kgm2, self.damping_nms_per_rad, self.stiffness_nm_per_rad,
                      self.pressure_gain_nm_per_kpa)
        system = (np.array([[0.0, 1.0], [-k / a, -b / a]]), np.array([[0.0], [n / a]]),
                  np.array([[180.0 / np.pi, 0.0]]), np.array([[0.0]]))
        ad, bd, cd, _, _ = signal.cont2discrete(system, 1.0 / rate_hz, method="zoh")
        x = np.zeros(2)
        out = np.empty(pressure_kpa.size)
        for i, p in enumerate(pressure_kpa):
            out[i] = (cd @ x)[0]
            x = ad @ x + bd[:, 0] * p
        return out


def random_steps(rng: np.random.Generator, n: int, rate_hz: float, low_kpa: float,
                 high_kpa: float, hold_s: float = 1.5) -> np.ndarray:
    """A command that steps to a new random level every hold_s."""
    hold = max(1, int(hold_s * rate_hz))
    levels = rng.uniform(low_kpa, high_kpa, size=n // hold + 1)
    return np.repeat(levels, hold)[:n]


def lab_sensor_noise(rng: np.random.Generator, n: int, rate_hz: float, white_deg: float = 0.1,
                     correlated_deg: float = 0.3, correlation_s: float = 0.1, drift_deg: float = 0.5,
                     adc_step_deg: float = 0.05) -> tuple[np.ndarray, float]:
    """What a flex sensor's analog chain adds to the angle: white noise, noise correlated
    over `correlation_s` (a first-order filtered source), a slow wandering offset of about
    `drift_deg`, then the ADC's steps. Returns the noise to add and the ADC step, which the
    caller applies to the noisy angle (quantise(angle + noise))."""
    a = np.exp(-1.0 / (correlation_s * rate_hz))
    drive = rng.normal(0.0, correlated_deg * np.sqrt(1.0 - a * a), n)
    correlated = signal.lfilter([1.0], [1.0, -a], drive)
    t = np.arange(n) / rate_hz
    phase = rng.uniform(0.0, 2.0 * np.pi)
    drift = drift_deg * np.sin(2.0 * np.pi * t / (4.0 * t[-1] + 1.0) + phase)  # a quarter-wave or so
    return rng.normal(0.0, white_deg, n) + correlated + drift + rng.uniform(-1.0, 1.0), adc_step_deg


def quantise(angle_deg: np.ndarray, step_deg: float) -> np.ndarray:
    return np.round(angle_deg / step_deg) * step_deg if step_deg > 0 else angle_deg


def stepped_recording(seed: int, seconds: float, rate_hz: float, stiffness_factor: float,
                      effects: dict | None = None):
    """A Problem of the truth finger on random steps with 0.3° white noise, against a
    nominal whose k is `stiffness_factor` times the truth's (and with `effects`)."""
    from hand_service.config.model import FingerModel
    from hand_service.diagnose.model.problem import build_problem

    truth = LinearFinger()
    rng = np.random.default_rng(seed)
    n = int(seconds * rate_hz)
    pressure = random_steps(rng, n, rate_hz, 0.0, 80.0)
    angle = truth.angle_deg(pressure, rate_hz) + rng.normal(0.0, 0.3, n)
    nominal = FingerModel(inertia_kgm2=truth.inertia_kgm2, damping_nms_per_rad=truth.damping_nms_per_rad,
                          stiffness_nm_per_rad=stiffness_factor * truth.stiffness_nm_per_rad,
                          pressure_gain_nm_per_kpa=truth.pressure_gain_nm_per_kpa, effects=effects or {})
    return build_problem(nominal, np.arange(n) / rate_hz, pressure, angle, rate_hz)
