"""Does the decrement drift with amplitude? A viscous finger says no; anything else is a
clue for `diagnose` (docs/physics.md §4).

Each cycle of a fitted decay gets its own amplitude R, from a least-squares sinusoid over
that one cycle. Between consecutive cycles the amplitude falls by ΔR. Viscous damping
loses a fixed fraction: ΔR = α·R. Dry friction (Coulomb) loses a fixed amount on top,
4·T_c/k a cycle (docs/physics.md §4): ΔR = α·R + β with β > 0. Damping that grows with speed
(air drag) makes β < 0. So the pooled regression ΔR = α·R̄ + β over every trial says
which, and β in degrees is the dry-friction loss per cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hand_service.identification.ldm import DecayEstimate, FreeDecay

MIN_T_STAT = 4.0  # β this many standard errors from zero ...
MIN_DRIFT = 0.2  # ... and a decrement that changes by this fraction over the amplitudes seen


@dataclass
class CycleAmplitudes:
    t_s: np.ndarray  # centre of each cycle
    amplitude_deg: np.ndarray
    noise_deg: float


@dataclass
class Drift:
    amplitude_loss_deg_per_cycle: float  # β
    loss_fraction_per_cycle: float  # α
    t_stat: float
    high_amplitude_deg: float
    low_amplitude_deg: float
    log_decrement_high: float  # δ implied at the high amplitude ...
    log_decrement_low: float  # ... and at the low one
    cycles: int

    @property
    def relative_drift(self) -> float:
        mean = 0.5 * (self.log_decrement_high + self.log_decrement_low)
        return (self.log_decrement_low - self.log_decrement_high) / mean if mean > 0 else 0.0

    @property
    def significant(self) -> bool:
        return abs(self.t_stat) >= MIN_T_STAT and abs(self.relative_drift) >= MIN_DRIFT

    @property
    def kind(self) -> str:
        if not self.significant:
            return "viscous"
        return "dry_friction" if self.amplitude_loss_deg_per_cycle > 0 else "amplitude_dependent"

    def friction_torque_nm(self, stiffness_nm_per_rad: float) -> float:
        """T_c from the loss per cycle, 4·T_c/k (docs/physics.md §4)."""
        return math.radians(self.amplitude_loss_deg_per_cycle) * stiffness_nm_per_rad / 4.0

    def warning(self, stiffness_nm_per_rad: float) -> str | None:
        if not self.significant:
            return None
        head = (f"the log decrement drifts with amplitude: {self.log_decrement_high:.3f} at "
                f"{self.high_amplitude_deg:.1f} deg, {self.log_decrement_low:.3f} at "
                f"{self.low_amplitude_deg:.1f} deg, so the damping is not viscous")
        if self.kind == "dry_friction":
            torque = self.friction_torque_nm(stiffness_nm_per_rad)
            loss = self.amplitude_loss_deg_per_cycle
            return (f"{head}: the amplitude also falls by a constant {loss:.2f} deg "
                    f"per cycle, the signature of dry friction (coulomb_friction torque_nm ~ {torque:.2g}, "
                    "docs/physics.md §4); k and B are averages over the decay: run `hand-service diagnose`")
        return (f"{head}: the decay is relatively faster at large amplitudes, like air drag "
                "(quadratic_damping); k and B are averages over the decay: run `hand-service diagnose`")

    def to_json(self) -> dict[str, float | int | str]:
        return {"kind": self.kind, "amplitude_loss_deg_per_cycle": self.amplitude_loss_deg_per_cycle,
                "loss_fraction_per_cycle": self.loss_fraction_per_cycle, "t_stat": self.t_stat,
                "log_decrement_high_amplitude": self.log_decrement_high,
                "log_decrement_low_amplitude": self.log_decrement_low,
                "high_amplitude_deg": self.high_amplitude_deg, "low_amplitude_deg": self.low_amplitude_deg,
                "cycles": self.cycles}


def cycle_amplitudes(decay: FreeDecay, fit: DecayEstimate) -> CycleAmplitudes:
    """Amplitude of each whole cycle of the fitted window while the fitted envelope stays
    above four times the noise. (Stopping on the envelope, not on the measured amplitude,
    keeps the last cycles free of a selection bias.)"""
    if fit.coefficients_deg is None or fit.rmse_deg is None:
        raise ValueError("cycle amplitudes need the damped-sine fit")
    sigma, omega, period = fit.decay_rate_per_s, fit.damped_freq_rad_per_s, fit.damped_period_s
    noise = fit.rmse_deg
    initial = math.hypot(fit.coefficients_deg[1], fit.coefficients_deg[2])
    centres, amplitudes = [], []
    start = fit.start_s
    while (start + period <= fit.end_s + 1e-9
           and initial * math.exp(-sigma * (start + 0.5 * period - fit.start_s)) >= 4.0 * noise):
        inside = (decay.t_s >= start) & (decay.t_s < start + period)
        t = decay.t_s[inside] - (start + 0.5 * period)
        if t.size >= 5:
            envelope = np.exp(-sigma * t)
            basis = np.column_stack([np.ones_like(t), envelope * np.cos(omega * t),
                                     envelope * np.sin(omega * t)])
            coefficients = np.linalg.lstsq(basis, decay.angle_deg[inside], rcond=None)[0]
            centres.append(start + 0.5 * period)
            amplitudes.append(math.hypot(coefficients[1], coefficients[2]))
        start += period
    return CycleAmplitudes(np.array(centres), np.array(amplitudes), noise)


def decrement_drift(cycles: list[CycleAmplitudes]) -> Drift | None:
    """The pooled regression ΔR = α·R̄ + β; None when there are too few cycles to tell."""
    loss, mean = [], []
    for c in cycles:
        loss.extend(c.amplitude_deg[:-1] - c.amplitude_deg[1:])
        mean.extend(0.5 * (c.amplitude_deg[:-1] + c.amplitude_deg[1:]))
    if len(loss) < 4:
        return None
    y, r = np.array(loss), np.array(mean)
    design = np.column_stack([r, np.ones_like(r)])
    (alpha, beta), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ np.array([alpha, beta])
    dof = max(1, y.size - 2)
    covariance = np.linalg.inv(design.T @ design) * float(residual @ residual) / dof
    se_beta = math.sqrt(max(covariance[1, 1], 1e-30))
    high, low = float(np.percentile(r, 90)), float(np.percentile(r, 10))

    def implied(amplitude: float) -> float:
        remaining = 1.0 - alpha - beta / amplitude
        return -math.log(max(remaining, 1e-3))  # a loss of (almost) all of it: capped

    return Drift(float(beta), float(alpha), float(beta / se_beta), high, low, implied(high), implied(low),
                 int(y.size))


__all__ = ["MIN_DRIFT", "MIN_T_STAT", "CycleAmplitudes", "Drift", "cycle_amplitudes", "decrement_drift"]
