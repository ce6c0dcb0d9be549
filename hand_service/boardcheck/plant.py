"""The plant through the board: every valve moves its chamber, every flex sensor moves with it.

The protocol checks can pass a board the daemon cannot use: valves that never open, a
chamber pressure reported where the profile says none is measured, or reported twice too
high, a flex sensor that never moves or moves at another scale than the profile's
calibration. This check vents, then commands --pressure-kpa on every finger until the
chambers settle, then vents again, and judges each finger against the profile:

- where safety.pressure_measured: the chamber must be reported (a NaN is the daemon's
  `pressure_lost` on the first sample) and settle within PRESSURE_TOL of the setpoint
  (the larger of PRESSURE_TOL_KPA and PRESSURE_TOL_FRACTION of it);
- the angle (the profile's calibration of the flex mV) must move by what the finger's
  model makes of the pressure step (pressure_gain / stiffness: the static bend), within
  a factor FLEX_SCALE_MAX either way; less than FLEX_STUCK_FRACTION of it is a sensor that
  does not move. Judged only where the chamber moved (or is not measured): a dead valve
  moves no finger, and is named as such.

A finger whose step the model bends less than FLEX_MIN_DEG cannot be judged (N/A for
its flex): raise --pressure-kpa. The check needs a supply: with it off, no chamber moves,
and it fails as a dead board would.
"""

from __future__ import annotations

import numpy as np

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.results import CheckResult, failed, not_made, verdict
from hand_service.boardcheck.session import Session, samples

VENT_S = 0.6  # vented before the step: the chambers empty, the fingers at rest
STEP_S = 1.2  # the setpoint held: the chambers and the fingers settle
TAIL_S = 0.25  # the settled values: the mean over the step's (and the vent's) last this long
PRESSURE_TOL_KPA = 3.0
PRESSURE_TOL_FRACTION = 0.25
FLEX_STUCK_FRACTION = 0.25  # the angle moved less than this share of the model's bend: stuck
FLEX_SCALE_MAX = 1.5  # ... more than this factor from it either way: another scale
FLEX_MIN_DEG = 3.0  # a smaller expected bend cannot tell a scale
# what a finger can get wrong, as the line says it
NAN_PRESSURE = ("chamber pressure NaN (not measured) where the profile measures it "
                "(safety.pressure_measured): the daemon faults pressure_lost")
DEAD_VALVE = "the valve did not move the chamber"


PRESSURE_SCALE = "the chamber reads at another scale than the setpoint it follows"
FLEX_STUCK = "flex sensor did not move with the pressure step"
FLEX_SCALE = "flex sensor moved at another scale than the profile's calibration and model"



def unsigned_zero(value: float, digits: int) -> float:
    """`value` rounded, with a noise-negative zero printed as 0 (not "-0.0 kPa")."""
    return round(value, digits) + 0.0


def _tail(got: list[Received], seconds: float) -> tuple[np.ndarray, np.ndarray, int]:
    """The mean flex mV and chamber kPa per finger over the last `seconds` of samples, and
    how many samples reported a NaN chamber (per finger: any)."""
    rows = samples(got)
    if not rows:
        raise ValueError("no sample")
    end = rows[-1][0]
    tail = [s for t, s in rows if t >= end - seconds] or [rows[-1][1]]
    mv = np.array([s.sensor_mv for s in tail], dtype=float)
    kpa = np.array([s.pressure_meas_kpa for s in tail], dtype=float)
    return mv.mean(axis=0), kpa.mean(axis=0), len(tail)


def _nan_fingers(got: list[Received]) -> np.ndarray:
    kpa = np.array([s.pressure_meas_kpa for _, s in samples(got)], dtype=float)
    return np.isnan(kpa).any(axis=0) if kpa.size else np.zeros(0, dtype=bool)


def plant(session: Session) -> CheckResult:
    cfg = session.settings
    name = "plant"
    fingers = cfg.fingers
    setpoint_kpa = cfg.pressure_kpa
    session.progress(f"the plant: vent, {setpoint_kpa:g} kPa on every finger for {STEP_S:g} s, vent")
    rest = session.pump(VENT_S, 0.0)
    step = session.pump(STEP_S, setpoint_kpa)
    session.pump(VENT_S / 2, 0.0)
    try:
        mv0, kpa0, _ = _tail(rest, TAIL_S)
        mv1, kpa1, _ = _tail(step, TAIL_S)
    except ValueError:
        return failed(name, "no sample while venting or commanding")
    nan = _nan_fingers(rest + step)
    tol_kpa = max(PRESSURE_TOL_KPA, PRESSURE_TOL_FRACTION * setpoint_kpa)
    problems: dict[str, list[tuple[str, str]]] = {}  # what is wrong -> (finger, its numbers)
    judged: list[str] = []
    values: dict[str, object] = {"setpoint_kpa": setpoint_kpa, "pressure_tolerance_kpa": tol_kpa,
                                 "pressure_measured": cfg.pressure_measured, "fingers": {}}
    for i, finger in enumerate(fingers):
        row: dict[str, object] = {}
        values["fingers"][finger.name] = row  # type: ignore[index]
        step_kpa = setpoint_kpa
        if cfg.pressure_measured:
            row.update(pressure_rest_kpa=float(kpa0[i]), pressure_kpa=float(kpa1[i]))
            if nan[i]:
                problems.setdefault(NAN_PRESSURE, []).append((finger.name, ""))
                continue
            if abs(kpa1[i] - setpoint_kpa) > tol_kpa:
                kind = DEAD_VALVE if abs(kpa1[i] - kpa0[i]) < tol_kpa else PRESSURE_SCALE
                problems.setdefault(kind, []).append(
                    (finger.name, f"{unsigned_zero(kpa1[i], 1):.1f} kPa, "
                                  f"{unsigned_zero(kpa1[i] / setpoint_kpa, 2):.2f}x"))
                continue
            step_kpa = float(kpa1[i] - kpa0[i])
        expected_deg = finger.bend_deg_per_kpa * step_kpa
        moved_deg = finger.gain_deg_per_mv * float(mv1[i] - mv0[i])
        row.update(flex_moved_deg=moved_deg, flex_expected_deg=expected_deg)
        if abs(expected_deg) < FLEX_MIN_DEG:
            row["flex"] = "not judged: the step bends it too little"
            continue
        ratio = moved_deg / expected_deg
        row["flex_ratio"] = ratio
        numbers = f"{moved_deg:+.1f} deg where the model bends it {expected_deg:+.1f} deg, {ratio:.2f}x"
        if ratio < FLEX_STUCK_FRACTION:
            problems.setdefault(FLEX_STUCK, []).append((finger.name, numbers))
        elif not 1.0 / FLEX_SCALE_MAX <= ratio <= FLEX_SCALE_MAX:
            problems.setdefault(FLEX_SCALE, []).append((finger.name, numbers))
        else:
            judged.append(f"{finger.name} {ratio:.2f}x")
    if problems:
        where = {DEAD_VALVE: f"for a {setpoint_kpa:g} kPa setpoint (±{tol_kpa:g})",
                 PRESSURE_SCALE: f"for a {setpoint_kpa:g} kPa setpoint (±{tol_kpa:g})",
                 FLEX_SCALE: f"allowed {1 / FLEX_SCALE_MAX:.2f}-{FLEX_SCALE_MAX:g}x"}
        lines = []
        for kind, found in problems.items():
            names = "every finger" if len(found) == len(fingers) > 1 else ", ".join(n for n, _ in found)
            numbers = "; ".join(f"{n} {x}" for n, x in found if x)
            extra = ", ".join(part for part in (numbers, where.get(kind, "")) if part)
            lines.append(f"{names}: {kind}" + (f" ({extra})" if extra else ""))
        return failed(name, "; ".join(lines), **values)
    if not judged and not cfg.pressure_measured:
        return not_made(name, f"no finger bends {FLEX_MIN_DEG:g} deg at {setpoint_kpa:g} kPa by its model, "
                        "and the board measures no pressure: raise --pressure-kpa", **values)
    pressure = (f"every chamber within ±{tol_kpa:g} kPa of {setpoint_kpa:g} kPa" if cfg.pressure_measured
                else "pressure not measured (profile)")
    flex = f"flex against the model's bend: {', '.join(judged)}" if judged else "no flex judged"
    return verdict(name, True, f"{pressure}; {flex}", **values)

