"""Calibrations from measured data: the pressure gain N, the flex sensor's mV → deg map,
and the valve's lag and dead time.

- `fit_pressure_gain`: a slow pressure sweep at quasi-static equilibrium, where
  N·p_eff = τ(θ) (k·θ plus the model's static effects). A linear regression
  τ = N·p + N_lag·ṗ + τ₀ gives N; the ṗ term soaks up what the valve and the finger
  trail behind a sweep, so up- and down-sweeps agree.
- `fit_sensor_map`: per finger, angle_deg = gain·mV + offset by least squares, with R².
- `fit_valve`: the measured chamber pressure after command steps against a first-order
  lag behind a dead time, integrated exactly for held commands; over every step, or over
  the rising or the falling steps alone (a pneumatic valve fills and vents at different
  rates: docs/identification.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize, signal, stats

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.config.plausible import VALVE_VENT_TAU_S
from hand_service.errors import UserError
from hand_service.recording import Recording
from rtcore import Effects, Prbm
from rtcore.reference import effective_pressure, model_torque
from rtcore.sim import SimFinger, simulate

MIN_SPAN_KPA = 10.0
MIN_PAIRS = 3
MIN_REPORTED_SHARE = 0.5  # of the samples: the board may leave pressure_meas_kpa out (NaN) now and then


@dataclass
class GainFit:
    pressure_gain_nm_per_kpa: float
    pressure_gain_se_nm_per_kpa: float
    offset_nm: float
    lag_s: float  # −N_lag / N: how far the angle trails the pressure (τ(θ(t)) ≈ N·p(t − lag))
    r_squared: float
    rmse_deg: float
    stiffness_nm_per_rad: float
    pressure_column: str
    pressure_kpa: np.ndarray  # effective pressure, per sample
    torque_nm: np.ndarray  # τ(θ), per sample
    residual_rad: np.ndarray

    def to_json(self) -> dict[str, Any]:
        return {"pressure_gain_nm_per_kpa": self.pressure_gain_nm_per_kpa,
                "pressure_gain_se_nm_per_kpa": self.pressure_gain_se_nm_per_kpa,
                "r_squared": self.r_squared, "rmse_deg": self.rmse_deg, "offset_nm": self.offset_nm,
                "lag_s": self.lag_s, "stiffness_nm_per_rad": self.stiffness_nm_per_rad,
                "pressure_column": self.pressure_column, "samples": int(self.pressure_kpa.size)}


def static_torque_nm(model: FingerModel, angle_rad: np.ndarray) -> np.ndarray:
    """τ(θ) at rest: k·θ plus the model's static effects (the C model's own formula)."""
    model.require("stiffness_nm_per_rad", purpose="calibrate gain (N = k·θ/p)")
    prbm = Prbm(inertia_kgm2=model.inertia_kgm2, damping_nms_per_rad=0.0,
                stiffness_nm_per_rad=model.stiffness_nm_per_rad,  # type: ignore[arg-type]
                pressure_gain_nm_per_kpa=1.0, lever_arm_m=1.0, effects=fx.to_rtcore(model.effects))
    return np.array([model_torque(prbm, float(a), 0.0) for a in angle_rad])


def _pressure(recording: Recording, which: str) -> tuple[str, np.ndarray, np.ndarray]:
    """The pressure column the fit uses, its gaps (NaN where the board did not report it,
    docs/formats.md) filled by interpolation, and which samples it reported. `auto` takes
    the measured pressure when the board reported at least MIN_REPORTED_SHARE of it."""
    measured = recording.columns.get("pressure_meas_kpa")
    reported = np.isfinite(measured) if measured is not None else np.zeros(len(recording), dtype=bool)
    share = float(reported.mean())
    if which == "measured" or (which == "auto" and share >= MIN_REPORTED_SHARE):
        if measured is None or share < MIN_REPORTED_SHARE:
            raise UserError(f"{recording.path}: the board reported pressure_meas_kpa in {share:.0%} of the "
                            f"samples (asked for --pressure measured; at least {MIN_REPORTED_SHARE:.0%} "
                            "is needed)")
        filled = np.interp(recording.t_s, recording.t_s[reported], measured[reported])
        return "pressure_meas_kpa", filled, reported
    return "pressure_kpa", recording.pressure_kpa, np.ones(len(recording), dtype=bool)


def fit_pressure_gain(recording: Recording, model: FingerModel, pressure: str = "auto") -> GainFit:
    """N from a slow sweep: τ(θ) = N·p_eff + N_lag·ṗ_eff + τ₀ by least squares."""
    column, p, reported = _pressure(recording, pressure)
    config_effects = fx.to_rtcore(model.effects)
    p_eff = np.array([effective_pressure(config_effects, float(v)) for v in p])
    if float(np.ptp(p_eff)) < MIN_SPAN_KPA:
        raise UserError(f"{recording.path}: the pressure spans only {np.ptp(p_eff):.3g} kPa; a sweep "
                        f"needs at least {MIN_SPAN_KPA:g} kPa (better: the finger's whole range)")
    dt = 1.0 / recording.sample_rate_hz
    window = max(5, int(0.25 * recording.sample_rate_hz) | 1)
    p_rate = signal.savgol_filter(p_eff, window, 2, deriv=1, delta=dt)
    # fitted where the pressure and its rate are the board's own: no gap within the window
    used = np.convolve(~reported, np.ones(window), mode="same") == 0
    torque = static_torque_nm(model, np.radians(recording.angle_deg))
    design = np.column_stack([p_eff, p_rate, np.ones_like(p_eff)])
    coefficients, *_ = np.linalg.lstsq(design[used], torque[used], rcond=None)
    residual = torque - design @ coefficients
    fitted = residual[used]
    dof = max(1, fitted.size - 3)
    covariance = np.linalg.inv(design[used].T @ design[used]) * float(fitted @ fitted) / dof
    gain = float(coefficients[0])
    if gain <= 0:
        raise UserError(f"{recording.path}: the angle does not grow with the pressure "
                        f"(fitted N = {gain:.3g}); is this a pressure sweep of this finger?")
    k = float(model.stiffness_nm_per_rad)  # type: ignore[arg-type]
    total = float(np.sum((torque[used] - torque[used].mean()) ** 2))
    return GainFit(gain, math.sqrt(covariance[0, 0]), float(coefficients[2]), -float(coefficients[1]) / gain,
                   1.0 - float(fitted @ fitted) / total if total > 0 else 0.0,
                   math.degrees(math.sqrt(float(np.mean(fitted**2))) / k), k, column, p_eff, torque,
                   residual / k)


@dataclass
class SensorFit:
    finger: str
    gain_deg_per_mv: float
    offset_deg: float
    r_squared: float
    rmse_deg: float
    pairs: int

    def to_json(self) -> dict[str, Any]:
        return {"sensor_gain_deg_per_mv": self.gain_deg_per_mv, "sensor_offset_deg": self.offset_deg,
                "r_squared": self.r_squared, "rmse_deg": self.rmse_deg, "pairs": self.pairs}


def fit_sensor_map(recording: Recording, finger: str | None = None) -> list[SensorFit]:
    """One linear map per finger (the `finger` column, else the one finger named)."""
    mv = recording.columns["sensor_mv"]
    angle = recording.columns["angle_deg"]
    names = recording.text_columns.get("finger")
    if names is None:
        if "finger" in recording.columns:
            raise UserError(f"{recording.path}: the finger column holds numbers, not finger names")
        name = finger or recording.metadata.get("finger") or "finger"
        groups = {name: np.arange(mv.size)}
    else:
        groups = {}
        for i, n in enumerate(names):
            groups.setdefault(n, []).append(i)  # type: ignore[attr-defined]
        if finger is not None:
            if finger not in groups:
                raise UserError(f"{recording.path}: no pairs for finger '{finger}' "
                                f"(fingers: {', '.join(groups)})")
            groups = {finger: groups[finger]}
    fits = []
    for name, rows in groups.items():
        x, y = mv[np.asarray(rows)], angle[np.asarray(rows)]
        if x.size < MIN_PAIRS:
            raise UserError(f"{recording.path}: finger '{name}' has {x.size} pair(s); "
                            f"at least {MIN_PAIRS} are needed")
        if float(np.ptp(x)) == 0.0:
            raise UserError(f"{recording.path}: finger '{name}': every sensor_mv is the same; "
                            "hold the finger at several angles")
        fit = stats.linregress(x, y)
        residual = y - (fit.slope * x + fit.intercept)
        fits.append(SensorFit(name, float(fit.slope), float(fit.intercept), float(fit.rvalue**2),
                              float(np.sqrt(np.mean(residual**2))), int(x.size)))
    return fits


VALVE_STEPS = ("all", "rising", "falling")


@dataclass
class ValveFit:
    tau_s: float
    delay_s: float
    rmse_kpa: float
    samples: int  # the samples fitted: after the steps of `steps`
    command_kpa: np.ndarray
    measured_kpa: np.ndarray
    model_kpa: np.ndarray
    steps: str = "all"  # VALVE_STEPS: which command steps the fit is judged on
    vent_tau_s: float = 0.0  # the lag while venting, where fitted apart (fit_valve's vent); 0: tau_s

    def to_json(self) -> dict[str, Any]:
        vent = {"valve_vent_tau_s": self.vent_tau_s} if self.vent_tau_s > 0.0 else {}
        return {"valve_lag_tau_s": self.tau_s, **vent, "dead_time_s": self.delay_s, "rmse_kpa": self.rmse_kpa,
                "samples": self.samples}

    def effects(self) -> fx.EffectParams:
        vent = {"valve_vent_lag": {"tau_s": self.vent_tau_s}} if self.vent_tau_s > 0.0 else {}
        return {"valve_lag": {"tau_s": self.tau_s}, **vent, "dead_time": {"delay_s": self.delay_s}}


# A finger that never moves (no pressure gain), only there to carry the valve through the
# simulator: the chamber then follows exactly the valve model the simulated truth uses.
_VALVE_PROBE = SimFinger(Prbm(inertia_kgm2=1.0, damping_nms_per_rad=1.0, stiffness_nm_per_rad=1.0,
                              pressure_gain_nm_per_kpa=0.0, lever_arm_m=1.0),
                         supply_min_kpa=-1e6, supply_max_kpa=1e6)


def valve_response_kpa(command_kpa: np.ndarray, dt_s: float, tau_s: float, delay_s: float,
                       vent_tau_s: float = 0.0) -> np.ndarray:
    """Chamber pressure at each sample for commands held one sample each, delayed by
    delay_s, through a first-order lag τ (vent_tau_s while it vents, 0: τ; the simulator's
    valve, csrc/rtcore_sim_plant.c: exact, with the delay's breakpoint inside a period).
    Sample k is read before command k acts."""
    probe = _VALVE_PROBE.replace(effects=Effects(valve_lag_tau_s=tau_s, dead_time_s=delay_s,
                                                 valve_vent_tau_s=vent_tau_s))
    _, chamber = simulate(probe, command_kpa, 1.0 / dt_s, substeps=1,
                          chamber0_kpa=float(command_kpa[0]))
    return chamber


def step_samples(command_kpa: np.ndarray, steps: str) -> np.ndarray:
    """Which samples follow a rising (or falling) change of the command, up to the next
    change; every sample for "all"."""
    if steps == "all":
        return np.ones(command_kpa.size, dtype=bool)
    change = np.flatnonzero(np.diff(command_kpa) != 0.0) + 1
    mask = np.zeros(command_kpa.size, dtype=bool)
    ends = [*change[1:], command_kpa.size]
    for start, end in zip(change, ends, strict=True):
        if (command_kpa[start] > command_kpa[start - 1]) == (steps == "rising"):
            mask[start:end] = True
    return mask


def fit_valve(recording: Recording, steps: str = "all", vent: bool = False) -> ValveFit:
    """The first-order lag and dead time whose response to the recorded commands best
    matches the measured chamber pressure, judged after the `steps` (VALVE_STEPS) only; with
    `vent`, the lag while the chamber vents fitted apart (the valve_vent_lag effect)."""
    measured = recording.columns.get("pressure_meas_kpa")
    if measured is None:
        raise UserError(f"{recording.path}: the valve fit needs the measured chamber pressure "
                        "(column pressure_meas_kpa)")
    reported = np.isfinite(measured)  # NaN where the board did not report it (docs/formats.md)
    if reported.mean() < MIN_REPORTED_SHARE:
        raise UserError(f"{recording.path}: the board reported pressure_meas_kpa in {reported.mean():.0%} of "
                        f"the samples; the valve fit needs at least {MIN_REPORTED_SHARE:.0%}")
    command = recording.pressure_kpa
    if float(np.ptp(command)) < MIN_SPAN_KPA:
        raise UserError(f"{recording.path}: the commands span only {np.ptp(command):.3g} kPa; step the "
                        f"valve by at least {MIN_SPAN_KPA:g} kPa")
    dt = 1.0 / recording.sample_rate_hz
    judged = step_samples(command, steps) & reported
    if not judged.any():
        raise UserError(f"{recording.path}: the commands have no {steps} step")

    def residual(params: np.ndarray) -> np.ndarray:
        return (valve_response_kpa(command, dt, *params) - measured)[judged]

    starts = [(tau, delay) for tau in (0.01, 0.03, 0.1) for delay in (0.0, 0.005, 0.02, 0.05)]
    best = min(starts, key=lambda s: float(np.sum(residual(np.array(s)) ** 2)))
    result = optimize.least_squares(residual, x0=best, bounds=([1e-4, 0.0], [0.5, 0.25]),
                                    x_scale=[0.01, 0.01], diff_step=1e-4)
    values = tuple(float(v) for v in result.x)
    if vent:  # from the symmetric fit, the vent's lag free
        result = optimize.least_squares(residual, x0=(*values, values[0]),
                                        bounds=([1e-4, 0.0, 1e-4], [0.5, 0.25, VALVE_VENT_TAU_S.upper]),
                                        x_scale=[0.01, 0.01, 0.01], diff_step=1e-4)
        values = tuple(float(v) for v in result.x)
    model = valve_response_kpa(command, dt, *values)
    return ValveFit(values[0], values[1], float(np.sqrt(np.mean((model - measured)[judged] ** 2))),
                    int(judged.sum()), command, measured, model, steps, *values[2:])


__all__ = ["VALVE_STEPS", "GainFit", "SensorFit", "ValveFit", "fit_pressure_gain", "fit_sensor_map",
           "fit_valve", "static_torque_nm", "step_samples", "valve_response_kpa"]
