"""Evidence a researcher can read: what each found effect does to this finger, in numbers.

An entry here is optional: an effect without one gets the generic sentence (its estimate
and the statistics), so adding an effect to the library needs nothing in this file.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.raw_error import RawErrors
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.recording.response_onset import delay_seen, onset_delay_s


@dataclass
class Context:
    """What the sentences may quote: the problem, the augmented finger's simulated angle and
    the found value of the effect, its fitted shape, and every candidate's ΔBIC in the
    round it was named in."""

    problem: Problem
    angle_deg: np.ndarray
    velocity_deg_per_s: np.ndarray
    stiffness_nm_per_rad: float
    damping_nms_per_rad: float
    value: float
    shape: dict[str, float] = field(default_factory=dict)
    round_bic: dict[str, float] = field(default_factory=dict)


def _valve_lag(c: Context) -> str:
    return (f"the angle trails the pressure command by about {1e3 * c.value:.1f} ms more than the model "
            "allows, rounding off every change of pressure: a first-order valve lag")


def _dead_time(c: Context) -> str:
    p = c.problem
    onset = onset_delay_s(p.pressure_kpa, p.measured_deg, p.rate_hz)
    if not delay_seen(c.value, onset, p.rate_hz):
        return (f"the model fits better with a transport delay of {1e3 * c.value:.1f} ms, yet the recorded "
                f"response starts {1e3 * (onset or 0.0):.0f} ms after the command's steps: the delay is not "
                "seen at the onset, so it stands for something else in the response")
    return (f"the finger starts to move about {1e3 * c.value:.1f} ms later after each change of pressure "
            "than the model predicts, with the shape of the response unchanged: a transport delay")


def _coulomb(c: Context) -> str:
    """What this recording shows of dry friction: how much of it the finger spent nearly
    still (where friction holds it), and, only if it swung freely, the decay per cycle the fitted
    friction gives (the model's figure: a play or a material's loop would give another)."""
    still = np.abs(c.velocity_deg_per_s) < SLOW_DEG_PER_S
    band_deg = np.degrees(c.value / c.stiffness_nm_per_rad)
    text = (f"dry friction of about {c.value:.2g} N·m: the finger can rest anywhere within "
            f"±{band_deg:.2g} deg of where its spring alone would put it, and it was nearly still "
            f"(under {SLOW_DEG_PER_S:g} deg/s) for {100 * still.mean():.0f} % of this recording")
    if free_swing_s(c) > 0.0:
        per_cycle_deg = np.degrees(4.0 * c.value / c.stiffness_nm_per_rad)
        text += (f"; by the fitted friction its free swings would lose about {per_cycle_deg:.2g} deg of "
                 "amplitude per cycle (4·Tc/k: the model's figure, not measured from the swings)")
    return text


SLOW_DEG_PER_S = 2.0  # the library's friction smoothing: below it, friction holds the finger
# a loop turning within this share of the recorded range turns as a sticking friction does
STICKING_TRAVEL_SHARE = 0.01


def _hysteresis(c: Context) -> str:
    """The loop's torque and travel; where the travel is a friction's (a hair of the range
    recorded), that Dahl's form is a friction model too, and, where the round it was named
    in measured it, how the library's smooth dry friction fared there."""
    text = f"a torque of up to {c.value:.2g} N·m holds the finger back, a loop in the angle"
    travel_deg = c.shape.get("travel_deg")
    if travel_deg is None:
        return text
    text += f" that turns over within about {travel_deg:.2g} deg of travel after each turn"
    span_deg = float(np.ptp(c.problem.measured_deg))
    if not (span_deg > 0.0 and travel_deg <= STICKING_TRAVEL_SHARE * span_deg):
        return text
    text += (f"; turning within {100.0 * travel_deg / span_deg:.2g} % of the {span_deg:.0f} deg recorded, "
             "it turns as a dry friction that sticks before it slides does (Dahl's form is a friction "
             "model too), so it may be such a friction")
    friction, own = c.round_bic.get("coulomb_friction"), c.round_bic.get("hysteresis")
    if friction is not None and own is not None and friction < own:
        text += (f"; the library's coulomb_friction, smooth below {SLOW_DEG_PER_S:g} deg/s so that a finger "
                 f"it holds creeps, gained ΔBIC {friction:.0f} against the loop's {own:.0f} in the round "
                 "the loop was named in")
    return text


def free_swing_s(c: Context) -> float:
    """Seconds of this recording in which the command held still (within 0.5 kPa for 0.5 s
    or more) while the finger swung through zero velocity at least twice: free swings."""
    p = c.problem.pressure_kpa
    rate = c.problem.rate_hz
    steady = np.abs(np.diff(p, prepend=p[0])) < 0.5
    total = 0.0
    start = None
    for i, flag in enumerate(np.append(steady, False)):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if i - start >= 0.5 * rate:
                v = c.velocity_deg_per_s[start:i]
                crossings = int(np.sum(np.diff(np.sign(v[np.abs(v) > SLOW_DEG_PER_S])) != 0))
                if crossings >= 2:
                    total += (i - start) / rate
            start = None
    return total


def _cubic(c: Context) -> str:
    peak = np.radians(np.percentile(np.abs(c.angle_deg), 99))
    extra = c.value * peak**3
    share = 100.0 * extra / (c.stiffness_nm_per_rad * peak)
    kind = "stiffens" if c.value > 0 else "softens"
    return (f"the finger {kind} as it bends: at {np.degrees(peak):.0f} deg the extra torque k3·θ³ is "
            f"{extra:.2g} N·m, {share:+.1f} % of k·θ")


def _gravity(c: Context) -> str:
    peak = np.radians(np.percentile(np.abs(c.angle_deg), 99))
    torque = c.value * (1.0 - np.cos(peak))
    share = 100.0 * torque / (c.stiffness_nm_per_rad * peak)
    return (f"a torque growing as 1 − cos θ, as gravity on a horizontal finger: G = {c.value:.2g} N·m, "
            f"{torque:.2g} N·m at {np.degrees(peak):.0f} deg ({share:+.1f} % of k·θ)")


def _asymmetric(c: Context) -> str:
    behind = c.angle_deg < 0
    seconds = behind.sum() / c.problem.rate_hz
    low = float(c.angle_deg.min())
    return (f"bending backwards the finger is {c.value:.2f}× as stiff as bending forwards; it swung "
            f"below zero (down to {low:.0f} deg) for {seconds:.1f} s of the recording")


def _quadratic(c: Context) -> str:
    speed = np.radians(np.percentile(np.abs(c.velocity_deg_per_s), 99))
    share = 100.0 * c.value * speed / max(c.damping_nms_per_rad, 1e-12)
    return (f"fast swings are damped more than slow ones (air drag c2·|θ'|·θ'): at {np.degrees(speed):.0f} "
            f"deg/s it adds {share:.0f} % to the viscous damping B")


def _deadzone(c: Context) -> str:
    command = c.problem.pressure_kpa
    inside = 100.0 * np.mean((command > 0) & (command < c.value))
    return (f"the first {c.value:.2g} kPa of pressure make no torque (the bellows' slack); "
            f"{inside:.0f} % of the recording's commands are inside that dead zone")


SENTENCES: dict[str, Callable[[Context], str]] = {
    "valve_lag": _valve_lag, "dead_time": _dead_time, "coulomb_friction": _coulomb,
    "cubic_stiffness": _cubic, "gravity": _gravity, "asymmetric_stiffness": _asymmetric,
    "quadratic_damping": _quadratic, "pressure_deadzone": _deadzone, "hysteresis": _hysteresis,
}


NOT_IDENTIFIABLE = "not identifiable"


UNKNOWN = "unknown: over 100 % of the value"


DIMENSIONLESS = "1"  # a ratio or a gain: printed without a unit


def uncertainty(std: float, unit: str = "", value: float | None = None) -> str:
    """`± 0.0021 s`, or "not identifiable" where the data leave the value free (an infinite
    or undefined standard deviation), never "± inf"; with the `value`, a std larger than it
    says the value is unknown, and so does one that only its two printed digits make larger
    (± 0.011 beside 0.010983): the reader sees the printed figures."""
    if not np.isfinite(std):
        return NOT_IDENTIFIABLE
    printed = f"{std:.2g}"
    text = f"± {printed}{f' {unit}' if unit and unit != DIMENSIONLESS else ''}"
    unknown = value is not None and max(std, float(printed)) > abs(value)
    return f"{text} ({UNKNOWN})" if unknown else text


def estimate(value: float, std: float, unit: str = "") -> str:
    """`0.03 ± 0.002 s`, or `0.03 s (not identifiable)`."""
    if not np.isfinite(std):
        return f"{value:.4g}{f' {unit}' if unit and unit != DIMENSIONLESS else ''} ({NOT_IDENTIFIABLE})"
    return f"{value:.4g} {uncertainty(std, unit, value)}"


def error_change(errors: RawErrors) -> str:
    """The raw and held-out RMS errors without and with the effect, side by side, in numbers
    only: no word of improvement, which would be false where the raw error grew."""
    raw, held = errors.raw_deg, errors.heldout_deg
    return (f"raw RMS error {raw['before']:.3f} → {raw['after']:.3f} deg, held-out "
            f"{held['before']:.3f} → {held['after']:.3f} deg")


def sentence(name: str, context: Context, std: float, delta_bic: float, z_heldout: float,
             errors: RawErrors, prior_gain: float = 0.0,
             shape: dict[str, tuple[float, float]] | None = None,
             derived: tuple[str, float, float, str] | None = None,
             alone: tuple[float, float, str] | None = None) -> str:
    """`errors`: "before" and "after" the effect, against the raw angle (raw_error.py);
    `shape`: its shape parameters fitted beside its size, (value, std) each; `derived`: what
    the recording fixes where the size trades with the shape (what, value, std, unit);
    `alone`: that quantity refitted with the refining parameters held (value, std, how),
    where it is determined there and not beside them."""
    spec = fx.BY_NAME[name]
    physics = SENTENCES[name](context) if name in SENTENCES else spec.physics
    units = {p.name: "" if p.unit == "1" else p.unit for p in spec.parameters}  # "1": a pure number
    fitted = "".join(f", {member} = {estimate(value, s, units[member])}"
                     for member, (value, s) in (shape or {}).items())
    if derived is not None:
        what, value, spread, unit = derived
        fitted += f"; {what} = {estimate(value, spread, unit)}"
        if alone is not None:
            fitted += f" ({estimate(alone[0], alone[1], unit)} {alone[2]})"
    text = (f"{physics}. Estimate {spec.param} = {estimate(context.value, std, spec.unit)}{fitted}; "
            f"the information criterion favours it by ΔBIC = {delta_bic:.0f}")
    if z_heldout > 2.0:
        return text + f"; {error_change(errors)} (z = {z_heldout:.1f})."
    return text + (f" (of which {prior_gain:.0f} because without it k, B and N must leave the nominal "
                   f"far beyond its stated uncertainty to fit); {error_change(errors)} "
                   f"(z = {z_heldout:.1f}): this recording alone cannot tell it from that refit.")
