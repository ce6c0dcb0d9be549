"""The sensor's noise measured without a stretch at rest: what of the misfit no torque driven by
the recording's own motion and command can make.

Where the command is never held (a PRBS, a chirp) there is no stretch at rest to measure the
noise on (residual/noise_bound.py), and the AR noise model (residual/noise.py) takes smooth
input-driven structure for correlated noise: on a PRBS, a damping that grows with the
pressure left several times the sensor's noise, the AR filter took most of it for noise, and
a stand-in was graded `complete` (docs/results.md §12.36).

A torque the model misses moves the angle through the finger's own dynamics: the misfit it
leaves is that torque through 1/(A·s² + B·s + k), the refitted finger's linear part. The
sensor's noise is independent of the command and of the motion the command drives. So the
misfit (offset and slow drift out) is regressed by least squares on a fixed set of candidate
torques, each a function of the model's simulated angle and speed and of the command, each
passed through the refitted finger's dynamics; what they cannot make is the noise estimate.
The regression cannot take the noise (it is independent of every regressor: only the few
degrees of freedom it has, against thousands of samples); a structure outside the set's span
stays in the estimate, so it errs towards a noise too high, which lets structure pass as
before, never towards calling a clean recording structured.

The high-frequency alternative (the spread of the angle's differences of order d, for white
noise σ·√C(2d, d)) measures the white part only: on a sensor whose noise is partly correlated
over a tenth of a second, it falls well under the noise (docs/results.md §12.39), and clean
recordings would be called structured. It is not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from rtcore.sim import SimFinger

# The regression's columns against the samples: under this many samples per column the
# least squares would take a visible share of the noise (k/n of its variance, more where the
# noise is correlated), and the estimate is unavailable.
MIN_SAMPLES_PER_COLUMN = 200
SPEED_SCALE_RAD_S = 0.05  # the speed over which a dry friction's sign turns, as a smooth step


@dataclass(frozen=True)
class DrivenNoise:
    noise_std_deg: float  # the misfit's RMS that no candidate torque makes
    misfit_std_deg: float  # the misfit's RMS (offset and slow drift out), the scored samples
    columns: int

    @property
    def ratio(self) -> float:
        return self.misfit_std_deg / self.noise_std_deg

    def exceeds(self, factor: float) -> bool:
        return self.ratio > factor

    def sentence(self, named: bool) -> str:
        who = "the model's misfit with the named effects" if named else "the refitted model's misfit"
        tail = ("structure the noise model takes for correlated noise remains" if named else
                "the noise model would take input-driven structure for correlated noise, so the "
                "recording is not called consistent")
        return (f"{who} ({self.misfit_std_deg:.3g} deg RMS, the sensor's offset and slow drift taken out) "
                f"is {self.ratio:.2g} times what of it no torque driven by the recorded command and the "
                f"finger's motion makes ({self.noise_std_deg:.3g} deg; the recording holds the command "
                f"nowhere long enough to measure the noise at rest): {tail}")


def candidate_torques(angle_deg: np.ndarray, pressure_kpa: np.ndarray, rate_hz: float) -> list[np.ndarray]:
    """Torques a missing effect could add, in the model's angle θ (rad), speed ω and the
    command p: pressure damping p·ω, a pressure-dependent stiffness θ·p, a spring's bend θ²
    and θ³, drag |ω|·ω, dry friction's sign, and the command's own shape (p, p², ṗ), with the
    linear terms θ and ω."""
    theta = np.radians(angle_deg)
    speed = np.gradient(theta) * rate_hz
    p = np.asarray(pressure_kpa, dtype=float)
    return [speed * p, theta * p, theta, theta**2, theta**3, np.abs(speed) * speed,
            np.tanh(speed / SPEED_SCALE_RAD_S), speed, p, p**2, np.gradient(p) * rate_hz]


def finger_filter(finger: SimFinger, rate_hz: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The finger's linear part 1/(A·s² + B·s + k) as a digital filter (b, a), by the
    bilinear transform; None where that is not a stable filter."""
    prbm = finger.prbm
    den = [prbm.inertia_kgm2, prbm.damping_nms_per_rad, prbm.stiffness_nm_per_rad]
    if not all(np.isfinite(den)) or min(den) <= 0.0:
        return None
    b, a, _ = signal.cont2discrete(([1.0], den), 1.0 / rate_hz, method="bilinear")
    b, a = np.ravel(b), np.ravel(a)
    if np.any(np.abs(np.roots(a)) >= 1.0):
        return None
    return b, a


def driven_noise(misfit_deg: np.ndarray, angle_deg: np.ndarray, pressure_kpa: np.ndarray,
                 scored: np.ndarray, rate_hz: float, finger: SimFinger) -> DrivenNoise | None:
    """The misfit (`misfit_deg`, offset and drift out) against what of it no candidate torque
    through the finger makes, over the `scored` samples; None where the estimate is
    unavailable (the finger's dynamics not a stable filter, too few samples)."""
    kept = scored.astype(bool)
    dynamics = finger_filter(finger, rate_hz)
    if dynamics is None:
        return None
    b, a = dynamics
    columns = []
    for torque in candidate_torques(angle_deg, pressure_kpa, rate_hz):
        column = signal.lfilter(b, a, torque - torque.mean())[kept]  # about its mean, through the finger
        size = float(np.linalg.norm(column))
        if size > 0.0 and np.isfinite(size):
            columns.append(column / size)
    if not columns or kept.sum() < MIN_SAMPLES_PER_COLUMN * (len(columns) + 1):
        return None
    m = misfit_deg[kept] - float(np.mean(misfit_deg[kept]))
    x = np.column_stack([np.ones(m.size) / np.sqrt(m.size), *columns])
    beta, *_ = np.linalg.lstsq(x, m, rcond=None)
    left = m - x @ beta
    noise_std = float(np.sqrt(np.mean(left * left)))
    if not noise_std > 0.0:
        return None
    return DrivenNoise(noise_std, float(np.sqrt(np.mean(m * m))), x.shape[1])


__all__ = ["DrivenNoise", "candidate_torques", "driven_noise", "finger_filter"]
