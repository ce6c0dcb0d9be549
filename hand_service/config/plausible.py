"""Physical plausibility of a finger's values: the range of each quantity for a soft finger
1–30 cm long, and the unit slip that would explain a value outside it.

The reasoning for each range is in docs/formats.md (Plausible ranges). A value outside its
range is said in one line naming the unit it looks written in (k = 570 N·m/rad: N·mm/rad?);
`calibrate`, `identify`, `diagnose` and `run` say it, and `--write-model` refuses to save it.
The valve's two time constants are the bounds `effects:` validates against.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.errors import UserError

FINGER_LENGTH_M = (0.01, 0.30)  # the fingers these ranges are for
FINGER = f"a finger of {FINGER_LENGTH_M[0] * 100:g}–{FINGER_LENGTH_M[1] * 100:g} cm"


@dataclass(frozen=True)
class Slip:
    """A unit a value may have been written in by mistake: `per_unit` of it make one of ours."""

    unit: str
    per_unit: float


@dataclass(frozen=True)
class Plausible:
    """The plausible range of one quantity; `zero_ok`: 0 means "absent" and is accepted."""

    symbol: str
    unit: str
    lower: float
    upper: float
    slips: tuple[Slip, ...] = ()
    zero_ok: bool = False

    def holds(self, value: float) -> bool:
        value = as_float(value)
        return (self.zero_ok and value == 0.0) or self.lower <= value <= self.upper

    def slip(self, value: float) -> Slip | None:
        """The first unit slip that would bring `value` into range (none for a number past
        any float, an integer of hundreds of digits)."""
        if not math.isfinite(as_float(value)):
            return None
        for slip in self.slips:
            if self.holds(value / slip.per_unit):
                return slip
        return None

    def message(self, value: float) -> str:
        """One line: the value, its range and the unit slip that explains it, if one does."""
        value = as_float(value)
        ratio = value / self.upper if value > self.upper else self.lower / value if value > 0 else math.inf
        side = "above" if value > self.upper else "below"
        text = (f"{self.symbol} = {value:.4g} {self.unit} is {ratio:.3g}× {side} the range "
                f"{self.lower:g}–{self.upper:g} {self.unit} for {FINGER}")
        slip = self.slip(value)
        if slip is None:
            return text
        return f"{text}: {slip.unit}? ({value:.4g} {slip.unit} = {value / slip.per_unit:.4g} {self.unit})"


def as_float(value: float) -> float:
    """`value` as a float; an integer too large for one is infinite."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


MM, CM, G = Slip("mm", 1e3), Slip("cm", 1e2), Slip("g", 1e3)
MS = Slip("ms", 1e3)

# the model's keys (docs/formats.md); the reasoning for each bound is in docs/formats.md
MODEL_RANGES: dict[str, Plausible] = {
    "length_m": Plausible("l", "m", *FINGER_LENGTH_M, (MM, CM)),
    "mass_kg": Plausible("m", "kg", 1e-4, 1.0, (G,)),
    "lever_arm_m": Plausible("r", "m", 1e-3, FINGER_LENGTH_M[1], (MM, CM)),
    "inertia_kgm2": Plausible("A", "kg·m²", 5e-10, 0.06,
                              (Slip("g·m²", 1e3), Slip("g·mm²", 1e9), Slip("g·cm²", 1e7), Slip("kg·mm²", 1e6),
                               Slip("kg·cm²", 1e4))),
    "stiffness_nm_per_rad": Plausible("k", "N·m/rad", 1e-5, 40.0,
                                      (Slip("N·mm/rad", 1e3), Slip("N·cm/rad", 1e2))),
    "damping_nms_per_rad": Plausible("B", "N·m·s/rad", 1e-9, 6.0,
                                     (Slip("N·mm·s/rad", 1e3), Slip("N·cm·s/rad", 1e2)),
                                     zero_ok=True),
    "pressure_gain_nm_per_kpa": Plausible("N", "N·m/kPa", 2e-6, 0.1,
                                          (Slip("N·mm/kPa", 1e3), Slip("N·m/bar", 1e2),
                                           Slip("N·cm/kPa", 1e2))),
}
# the profile's finger keys beside the model
PROFILE_RANGES: dict[str, Plausible] = {
    "pressure_max_kpa": Plausible("pressure_max", "kPa", 10.0, 1000.0,
                                  (Slip("Pa", 1e3), Slip("bar", 1e-2))),
    "sensor_gain_deg_per_mv": Plausible("sensor_gain", "deg/mV", 1e-3, 10.0,
                                        (Slip("deg/V", 1e3), Slip("rad/mV", math.pi / 180.0))),
}
# the valve's effects (config/effects.py validates against these bounds)
VALVE_LAG_TAU_S = Plausible("valve_lag.tau_s", "s", 0.0, 0.5, (MS,))
VALVE_VENT_TAU_S = Plausible("valve_vent_lag.tau_s", "s", 0.0, 2.0, (MS,))
DEAD_TIME_DELAY_S = Plausible("dead_time.delay_s", "s", 0.0, 0.25, (MS,))


@dataclass(frozen=True)
class Derived:
    """A quantity computed from the model: its range and the keys it is computed from."""

    range: Plausible
    keys: tuple[str, ...]
    value: Callable[[dict[str, float]], float]


DERIVED: tuple[Derived, ...] = (
    Derived(Plausible("f_n", "Hz", 0.2, 200.0), ("stiffness_nm_per_rad", "inertia_kgm2"),
            lambda v: math.sqrt(v["stiffness_nm_per_rad"] / v["inertia_kgm2"]) / (2.0 * math.pi)),
    Derived(Plausible("ζ", "", 0.002, 10.0, zero_ok=True),
            ("damping_nms_per_rad", "stiffness_nm_per_rad", "inertia_kgm2"),
            lambda v: v["damping_nms_per_rad"] / (2.0 * math.sqrt(v["stiffness_nm_per_rad"]
                                                                  * v["inertia_kgm2"]))),
)


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def implausible(values: dict[str, Any], ranges: dict[str, Plausible] | None = None) -> list[str]:
    """One line per value outside its range; a derived quantity (natural frequency, damping
    ratio) outside its range names the key whose unit slip would bring it back."""
    ranges = MODEL_RANGES if ranges is None else ranges
    numbers = {k: n for k, v in values.items() if (n := _number(v)) is not None}
    lines = [ranges[k].message(n) for k, n in numbers.items() if k in ranges and not ranges[k].holds(n)]
    if lines:  # a direct slip explains the rest
        return lines
    for derived in DERIVED:
        if any(numbers.get(k) is None or (numbers[k] <= 0.0 and k != "damping_nms_per_rad")
               for k in derived.keys):
            continue
        value = derived.value(numbers)
        if derived.range.holds(value):
            continue
        line = derived.range.message(value)
        for key in derived.keys:
            for slip in MODEL_RANGES[key].slips:
                fixed = {**numbers, key: numbers[key] / slip.per_unit}
                if MODEL_RANGES[key].holds(fixed[key]) and derived.range.holds(derived.value(fixed)):
                    line += (f": {MODEL_RANGES[key].symbol} = {numbers[key]:.4g} in {slip.unit}? "
                             f"(= {fixed[key]:.4g} {MODEL_RANGES[key].unit})")
                    break
            else:
                continue
            break
        lines.append(line)
    return lines


def model_values(model: Any) -> dict[str, Any]:
    """The model keys of a FingerModel (or anything with those attributes)."""
    return {key: getattr(model, key, None) for key in MODEL_RANGES}


def warn_implausible(model: Any, source: str | Path | None = None, finger: str | None = None) -> list[str]:
    """The implausible values of a model, each as its one line (prefixed with where it is)."""
    where = str(source if source is not None else getattr(model, "source", "model"))
    name = finger if finger is not None else getattr(model, "finger", None)
    prefix = f"{where}: " + (f"finger {name}: " if name else "")
    return [f"{prefix}{line}" for line in implausible(model_values(model))]


def profile_warnings(profile: Any) -> list[str]:
    """The implausible values of every finger of a profile (its model and its own keys)."""
    lines = []
    for finger in profile.fingers:
        where = f"{profile.path}: finger {finger.name}: "
        values = {key: getattr(finger, key) for key in PROFILE_RANGES}
        lines += [where + line for line in (implausible(model_values(finger.model))
                                            + implausible(values, PROFILE_RANGES))]
    return lines


def say_implausible(model: Any, finger: str | None = None) -> list[str]:
    """Print a model's implausible values to stderr, one `warning:` line each; returns them."""
    lines = warn_implausible(model, finger=finger)
    for line in lines:
        print(f"warning: {line}", file=sys.stderr)
    return lines


def explained(refusal: UserError, lines: list[str]) -> UserError:
    """A command's refusal of a model, with the first unit slip found in it, still one line."""
    return UserError(f"{refusal} ({lines[0]})") if lines else refusal


def refuse_implausible(model: Any, path: str | Path) -> None:
    """UserError (exit 2) before a model with an implausible value is written to `path`."""
    lines = implausible(model_values(model))
    if lines:
        raise UserError(f"not writing {path}: {lines[0]} (docs/formats.md, plausible ranges)")


__all__ = [
    "DEAD_TIME_DELAY_S",
    "DERIVED",
    "FINGER",
    "MODEL_RANGES",
    "PROFILE_RANGES",
    "VALVE_LAG_TAU_S",
    "Plausible",
    "Slip",
    "explained",
    "implausible",
    "model_values",
    "profile_warnings",
    "refuse_implausible",
    "say_implausible",
    "warn_implausible",
]
