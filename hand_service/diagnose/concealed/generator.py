"""Concealed recordings: a hidden effect scaled until a refitted plain model almost hides it.

Concealed means two things at once (issue 6):

- after the plain PRBM's k, B and N (A held) are refitted to the noise-free response of
  the truth, what the effect leaves behind has an RMS of `ratio` times the sensor noise,
  with `ratio` in 0.4-1.5: nobody can see it in a plot;
- the nominal model handed to `diagnose` has k, B and N off by up to ±10 %, as LDM
  estimates are.

The truth is the model (with the effects in its `effects` block) plus the hidden effect;
the recording is the C simulator's, with sensor noise and ADC quantisation, seeded.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.diagnose.concealed.excitations import EXCITATIONS
from hand_service.diagnose.fitting.output_error import fit
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN, build_problem, substeps_for
from hand_service.errors import UserError
from hand_service.simulator import sim_finger
from rtcore.sim import Simulator

FULL_ANGLE_DEG = 80.0  # the excitations' full pressure bends the finger this far at rest


@dataclass
class Concealed:
    """A generated recording with its hidden truth."""

    t_s: np.ndarray
    pressure_kpa: np.ndarray
    angle_deg: np.ndarray  # what the sensor read (noise, ADC)
    angle_true_deg: np.ndarray  # the truth, noise-free
    truth: FingerModel  # true plain parameters and every true effect
    nominal: FingerModel  # what diagnose is given: perturbed plain parameters, known effects only
    hidden: fx.EffectParams  # the effects the nominal model leaves out
    concealment: float  # refitted plain model's residual RMS / sensor noise (0 when nothing is hidden)
    noise_deg: float
    excitation: str
    seed: int
    extra: dict[str, float] = field(default_factory=dict)

    def metadata(self) -> dict[str, object]:
        hidden = ", ".join(f"{n}={p[fx.BY_NAME[n].param]:.6g}" for n, p in self.hidden.items()) or "none"
        rate_hz = 1.0 / (self.t_s[1] - self.t_s[0])
        return {"finger": self.truth.finger or "finger", "sample_rate_hz": f"{rate_hz:g}",
                "source": "hand-service simulate (concealed-effect generator)",
                "excitation": self.excitation, "seed": self.seed, "sensor_noise_deg": self.noise_deg,
                "hidden_effects": hidden, "concealment_residual_over_noise": f"{self.concealment:.3f}"}


def full_pressure_kpa(model: FingerModel) -> float:
    return float(model.stiffness_nm_per_rad * np.radians(FULL_ANGLE_DEG) / model.pressure_gain_nm_per_kpa)


def plain_residual_rms(truth: FingerModel, known: fx.EffectParams, command_kpa: np.ndarray,
                       rate_hz: float) -> tuple[float, np.ndarray]:
    """RMS of what the refitted plain model (with the `known` effects) leaves of the truth's
    noise-free response, and that response."""
    t = np.arange(command_kpa.size) / rate_hz
    angle = np.zeros_like(t)
    plain_model = truth.with_changes(effects=known)
    problem = build_problem(plain_model, t, command_kpa, angle, rate_hz)
    clean = problem.simulate(sim_finger(truth))
    if not np.all(np.isfinite(clean)):
        return np.inf, clean
    problem.measured_deg = clean
    problem.fit_mask = problem.fit_mask | problem.held_mask
    params = [Param.plain(name, getattr(truth, name)) for name in PLAIN]
    refit = fit(problem, params, [getattr(truth, name) for name in PLAIN], base=problem.base)
    mask = problem.fit_mask
    return float(np.sqrt(np.mean((refit.angle_deg[mask] - clean[mask]) ** 2))), clean


def conceal_magnitude(base: FingerModel, name: str, sign: float, ratio: float, noise_deg: float,
                      command_kpa: np.ndarray, rate_hz: float) -> tuple[float, float]:
    """The parameter of effect `name` (deviating from neutral in direction `sign`) whose
    refitted-plain residual is `ratio` x the noise; returns (value, achieved ratio).

    Secant iterations on the logarithm of the deviation: for small deviations the residual
    grows in proportion, so a few steps suffice."""
    spec = fx.BY_NAME[name]
    target = ratio * noise_deg
    limit = (spec.upper if sign > 0 else spec.lower) - spec.neutral

    def residual_for(deviation: float) -> float:
        truth = base.with_changes(effects={**base.effects, name: {spec.param: spec.neutral + deviation}})
        rms = plain_residual_rms(truth, base.effects, command_kpa, rate_hz)[0]
        return rms if np.isfinite(rms) and rms < 1e3 else np.inf  # inf: the truth ran away

    deviation = sign * spec.scale
    achieved = residual_for(deviation)
    for _ in range(10):
        if abs(achieved / target - 1.0) < 0.03:
            break
        factor = target / max(achieved, 1e-12) if np.isfinite(achieved) else 0.3
        deviation = float(np.clip(deviation * np.clip(factor, 0.1, 10.0), -abs(limit), abs(limit)))
        achieved = residual_for(deviation)
    return spec.neutral + deviation, achieved / noise_deg


def perturb(model: FingerModel, fraction: float, rng: np.random.Generator) -> FingerModel:
    """k, B and N each scaled by a factor drawn uniformly within ±fraction."""
    changes = {name: getattr(model, name) * (1.0 + rng.uniform(-fraction, fraction)) for name in PLAIN}
    return model.with_changes(**changes)


def record(truth: FingerModel, command_kpa: np.ndarray, rate_hz: float, noise_deg: float,
           adc_step_deg: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The sensor angle (noise, ADC) and the true angle at every sample, from rest."""
    finger = sim_finger(truth, sensor_noise_deg=noise_deg, adc_step_mv=adc_step_deg)
    sim = Simulator([finger], sample_rate_hz=rate_hz, substeps=substeps_for(rate_hz), seed=seed)
    measured = np.empty(command_kpa.size)
    true = np.empty(command_kpa.size)
    measured[0], true[0] = sim.outputs.sensor_mv[0], sim.outputs.angle_deg[0]
    for k in range(command_kpa.size - 1):
        sim.command_kpa[0] = command_kpa[k]
        sim.step()
        measured[k + 1], true[k + 1] = sim.outputs.sensor_mv[0], sim.outputs.angle_deg[0]
    return measured, true


def generate(model: FingerModel, hidden: dict[str, float | None], excitation: str = "steps",
             duration_s: float = 30.0, rate_hz: float = 100.0, noise_deg: float = 0.5,
             adc_step_deg: float = 0.122, perturbation: float = 0.1, seed: int = 0,
             conceal_ratio: float | None = 0.8) -> Concealed:
    """A concealed recording of `model` with `hidden` effects.

    `hidden` maps an effect name to its parameter, or to None to have it scaled until the
    refitted plain model's residual is `conceal_ratio` x the noise (then the sign of the
    deviation from neutral is positive; pass a negative `conceal_ratio` for the other way).
    Effects in `hidden` are left out of the nominal model even if `model` includes them."""
    if excitation not in EXCITATIONS:
        raise UserError(f"unknown excitation '{excitation}' (known: {', '.join(EXCITATIONS)})")
    for name in hidden:
        if name not in fx.BY_NAME:
            raise UserError(f"unknown effect '{name}' (known: {', '.join(fx.BY_NAME)})")
    rng = np.random.default_rng(seed)
    command = EXCITATIONS[excitation](full_pressure_kpa(model), duration_s, rate_hz, rng)
    known = {n: p for n, p in model.effects.items() if n not in hidden}
    base = model.with_changes(effects=known)
    true_effects = dict(known)
    for name, value in hidden.items():
        spec = fx.BY_NAME[name]
        if value is None:
            if conceal_ratio is None:
                raise UserError(f"give {name} a value or a concealment ratio")
            sign = 1.0 if conceal_ratio > 0 else -1.0
            value, _ = conceal_magnitude(base.with_changes(effects=true_effects), name, sign,
                                         abs(conceal_ratio), noise_deg, command, rate_hz)
        true_effects[name] = {spec.param: float(value)}
    truth = model.with_changes(effects=true_effects)
    concealment = plain_residual_rms(truth, known, command, rate_hz)[0] / noise_deg if hidden else 0.0
    measured, true = record(truth, command, rate_hz, noise_deg, adc_step_deg, seed)
    nominal = perturb(base, perturbation, rng)
    hidden_params = {n: true_effects[n] for n in hidden}
    return Concealed(np.arange(command.size) / rate_hz, command, measured, true, truth, nominal,
                     hidden_params, concealment, noise_deg, excitation, seed)


__all__ = ["Concealed", "conceal_magnitude", "generate", "perturb", "plain_residual_rms"]
