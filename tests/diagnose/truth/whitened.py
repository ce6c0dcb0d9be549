"""What a battery case's effect leaves once the sensor's correlated noise is weighed as a
correct likelihood weighs it: an analysis of single cases, beside the battery's judge.

The battery's judge (distinct.py) measures what k, B and N, the sensor's offset and drift
and a competitor leave of an effect as an RMS over the noise's RMS: a white-noise yardstick,
linearised about the truth's plain finger. Here the same question is asked of one case
under the truth sensor's own noise: residuals pass through its innovations filter
(`Whitener`, exact for white noise plus an AR(1) part plus the ADC's rounding, an
ARMA(1,1)), and k, B and N are fitted in earnest (not linearised), held by the lab's ±25 %
prior. What is left, over the innovations' RMS, says how much the recording really shows;
its energy (the sum of squares) is about the ΔBIC a perfect form of the effect could earn.

Not the battery's observability rule: put in the judge's place with its bar (0.4 per
sample), an earlier form of this fit (two starts) called 71 of the 187 observable cases
unobservable, 68 of which diagnose names first (2026-11-27). It is for reading single
misses, such as the two over-damped free releases with air drag:

    .venv/bin/python -m tests.diagnose.truth.whitened \\
        quadratic_damping-free_release-s1-concealed-overdamped-200hz
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize, signal

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth import excitation as ex
from tests.diagnose.truth.distinct import (
    COMPETITORS,
    NOMINAL_RELATIVE_WIDTH,
    nuisance_columns,
    plain_sensitivities,
    torque_response_rad,
)
from tests.diagnose.truth.linear import DEG, LinearModel, response_deg
from tests.diagnose.truth.sensor import Sensor


@dataclass(frozen=True)
class Whitener:
    """e = (1 − pole·L) / (1 − zero·L) · n: what the noise n cannot predict of itself, of RMS
    `std_deg`."""

    pole: float
    zero: float
    std_deg: float

    def apply(self, x: np.ndarray) -> np.ndarray:
        return signal.lfilter([1.0, -self.pole], [1.0, -self.zero], np.asarray(x, dtype=float), axis=0)


def sensor_whitener(sensor: Sensor, rate_hz: float) -> Whitener:
    """The sensor's noise is an AR(1) part of pole a plus white parts (the white noise and the
    ADC's rounding, step²/12): an ARMA(1,1), (1 − aL)·n = (1 − bL)·e. The lag-0 and lag-1
    autocovariances of (1 − aL)·n, γ0 = σc²(1 − a²) + σw²(1 + a²) and γ1 = −a·σw², give the
    invertible zero b (b / (1 + b²) = −γ1 / γ0) and e's variance −γ1 / b."""
    white2 = sensor.white_deg**2 + sensor.adc_step_deg**2 / 12.0
    if sensor.correlated_deg <= 0.0:
        return Whitener(0.0, 0.0, math.sqrt(white2))
    a = math.exp(-1.0 / (sensor.correlation_s * rate_hz))
    g0 = sensor.correlated_deg**2 * (1.0 - a * a) + white2 * (1.0 + a * a)
    r = a * white2 / g0
    if r <= 0.0:
        return Whitener(a, 0.0, math.sqrt(g0))
    b = (1.0 - math.sqrt(1.0 - 4.0 * r * r)) / (2.0 * r)
    return Whitener(a, b, math.sqrt(a * white2 / b))


@dataclass(frozen=True)
class Leftover:
    rms: float  # over the innovations' RMS, per sample
    energy: float  # the sum of squares, in innovation variances
    factors: tuple[float, ...]  # the fitted k, B (and N) over the truth's plain finger's


def leftover(effect: str, theta_deg: np.ndarray, command_kpa: np.ndarray, rate_hz: float,
             plain: LinearModel, theta0_deg: float, whitener: Whitener,
             also_from: tuple[float, ...] = ()) -> Leftover:
    """The effect's signature after k, B and N (nonlinear, held by the prior), the offset and
    drift and the competitor, through `whitener`. Started from the plain finger, from one
    linearised step about it and from the factors `also_from` (another fit's); the best fit
    counts."""
    theta = np.asarray(theta_deg, dtype=float)
    command = np.asarray(command_kpa, dtype=float)
    _, form = COMPETITORS.get(effect, ("", None))
    torque = form(theta * DEG) if form is not None else None
    nuisance = whitener.apply(nuisance_columns(theta.size))
    n_plain = 3 if np.ptp(command) > 0.0 else 2  # N is not seen when the command never moves

    def model_at(x: np.ndarray) -> LinearModel:
        gain = plain.gain_nm_per_kpa * (math.exp(x[2]) if x.size > 2 else 1.0)
        return replace(plain, stiffness_nm_per_rad=plain.stiffness_nm_per_rad * math.exp(x[0]),
                       damping_nms_per_rad=plain.damping_nms_per_rad * math.exp(x[1]), gain_nm_per_kpa=gain)

    def residuals(x: np.ndarray) -> np.ndarray:
        model = model_at(x)
        miss = whitener.apply(theta - response_deg(model, command, rate_hz, theta0_deg))
        columns = nuisance
        if torque is not None:
            pull = whitener.apply(torque_response_rad(model, torque, rate_hz) / DEG)
            columns = np.column_stack((nuisance, pull))
        coeffs, *_ = np.linalg.lstsq(columns, miss, rcond=None)
        return np.concatenate(((miss - columns @ coeffs) / whitener.std_deg, x / NOMINAL_RELATIVE_WIDTH))

    sens = whitener.apply(plain_sensitivities(plain, command, rate_hz, theta0_deg)[:, :n_plain])
    miss0 = whitener.apply(theta - response_deg(plain, command, rate_hz, theta0_deg))
    stacked = np.column_stack((sens, nuisance))
    prior = np.zeros((n_plain, stacked.shape[1]))
    prior[:, :n_plain] = np.eye(n_plain) * whitener.std_deg / NOMINAL_RELATIVE_WIDTH
    step, *_ = np.linalg.lstsq(np.vstack((stacked, prior)), np.concatenate((miss0, np.zeros(n_plain))),
                               rcond=None)
    starts = [np.zeros(n_plain), np.clip(step[:n_plain], -3.0, 3.0)]
    if also_from:
        starts.append(np.log(np.asarray(also_from[:n_plain], dtype=float)))
    fits = [optimize.least_squares(residuals, x0, method="lm") for x0 in starts]
    best = min(fits, key=lambda f: f.cost)
    left = best.fun[: theta.size]
    return Leftover(float(np.sqrt(np.mean(left**2))), float(left @ left),
                    tuple(float(math.exp(v)) for v in best.x))


def spec_of(case_id: str) -> cs.CaseSpec:
    """The spec a battery id names: effect-excitation-sSEED-magnitude-family-RATEhz, with a
    -DURATIONs tail where the case is not 30 s long. ValueError, in words, if it names none."""
    parts = case_id.split("-")
    duration_s = 30.0
    if len(parts) == 7 and parts[-1].endswith("s"):
        try:
            duration_s = float(parts.pop()[:-1])
        except ValueError:
            raise ValueError(f"not a battery case id: {case_id}") from None
    if len(parts) != 6:
        raise ValueError(f"not a battery case id: {case_id}")
    effect, excitation, seed, magnitude, family, rate = parts
    checks = ((effect in cs.ALL_EFFECTS, f"unknown effect {effect!r}"),
              (excitation in ex.CLASSES, f"unknown excitation {excitation!r}"),
              (seed[:1] == "s" and seed[1:].isdigit(), f"seed {seed!r} is not s<number>"),
              (magnitude in ("concealed", "evident", "none"), f"unknown magnitude {magnitude!r}"),
              (family in cs.FAMILY_NAMES, f"unknown family {family!r}"),
              (rate.endswith("hz") and rate[:-2].isdigit() and float(rate[:-2]) in cs.RATES,
               f"rate {rate!r} is none of {', '.join(f'{r:g}hz' for r in cs.RATES)}"))
    for ok, why in checks:
        if not ok:
            raise ValueError(f"{case_id}: {why}")
    return cs.CaseSpec(effect, excitation, int(seed[1:]), magnitude, family, float(rate[:-2]),
                       duration_s=duration_s)


def analyse(case_id: str) -> dict:
    case = cs.build(spec_of(case_id))
    family = cs.FAMILIES[case.spec.resolved().family]
    plain = cs.plain_finger(family, case.truth, case.nominal.valve_tau_s, case.nominal.delay_s)  # the judge's
    traj = case.trajectory
    whitener = sensor_whitener(case.sensor, case.plan.rate_hz)
    args = (case.spec.effect, traj.theta_deg, traj.command_kpa, case.plan.rate_hz, plain,
            case.plan.theta0_deg)
    weighed = leftover(*args, whitener)
    # each fit also from the other's answer: a fit of a slow release can stall far from it
    white = leftover(*args, Whitener(0.0, 0.0, case.sensor.noise_rms_deg), weighed.factors)
    weighed = leftover(*args, whitener, white.factors)
    return {"id": case_id, "observable": case.observable, "visibility": case.visibility,
            "white": white, "whitened": weighed}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tests.diagnose.truth.whitened",
        description="What a battery case's effect leaves after k, B, N (fitted, ±25 % prior), the "
                    "sensor's offset and drift and a competitor: under white noise and under the "
                    "truth sensor's own correlated noise (its innovations).")
    ap.add_argument("case_id", nargs="+", help="a battery case id, e.g. "
                    "quadratic_damping-free_release-s1-concealed-overdamped-200hz")
    args = ap.parse_args(argv)
    bad = []
    for case_id in args.case_id:
        try:
            spec_of(case_id)
        except ValueError as exc:
            bad.append(str(exc))
    if bad:
        print("\n".join(f"whitened: {why}" for why in bad), file=sys.stderr)
        return 2
    for case_id in args.case_id:
        row = analyse(case_id)
        w, g = row["white"], row["whitened"]
        print(f"{case_id}: visibility {row['visibility']:.2f}; left under white noise {w.rms:.2f} "
              f"(energy {w.energy:.0f}); under the sensor's noise {g.rms:.2f} (energy {g.energy:.0f}); "
              f"k, B, N × {', '.join(f'{f:.2f}' for f in g.factors)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
