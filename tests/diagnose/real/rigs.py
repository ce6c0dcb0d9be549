"""The real rigs beyond Silverbox and EMPS: from each public raw file, a `diagnose` fixture.

Usage (the raw files are not in the repository; sources.py and README.md say where they are):

    python -m tests.diagnose.real.rigs RAW_DIR [--only RIG ...] [--out DIR]

RAW_DIR holds each source file under its own base name (dataBenchmark.csv, Circle_2bar.csv,
drive.mat, ...). For every rig this writes `<rig>.csv` (docs/formats.md §1),
`<rig>_model.yaml` (the nominal model: a linear output-error fit made here by odefit.py,
not by `hand_service`) and `<rig>_expected.json` (the expectation written before `diagnose`
ran, README.md §6 gives its reasoning; the scaling; the source).

The mapping onto A·θ'' + B·θ' + k·θ = N·p: angle_deg = deg_per_unit·(y − y_ref),
pressure_kpa = kpa_per_unit·(u − u_ref) (u_ref, y_ref the means unless the rig fixes them),
and time compressed where the rig is slower than a
finger (a sample of the source becomes `dt_s` of the fixture; every time in the rig, a
delay or a time constant, shrinks by the same factor).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tests.diagnose.real import sources
from tests.diagnose.real.odefit import FloatArray, Recording, fit_ode, fit_summary, write_csv, write_model

HERE = Path(__file__).resolve().parent
ANGLE_SPAN_DEG = 40.0  # the span the output is scaled to, when the rig does not fix it
PRESSURE_SPAN_KPA = 100.0
NO_SPRING_K = 0.05  # k/A (1/s²) held where the free linear fit finds no spring (k ≤ 0)
NEGATIVE_VERDICTS = ("unexplained", "insufficient_excitation")


@dataclass(frozen=True)
class Expectation:
    """What `diagnose` should say, decided from the source's physics before it was run.

    kind: "missing_physics" (a library effect is documented), "no_library_effect" (the physics
    is linear or outside the library, but the logged input drives the output) or
    "negative_control" (the input has no authority, a second input is unlogged, or the physics
    is outside the library by construction). `acceptable_effects` are the library names that
    would not be wrong if named; `acceptable_verdicts` the verdicts that are right.
    """

    kind: str
    effect: str | None
    acceptable_effects: tuple[str, ...]
    acceptable_verdicts: tuple[str, ...]
    control: str | None  # "no_authority" | "unlogged_input" | "outside_library" | None
    reason: str


@dataclass(frozen=True)
class Rig:
    name: str
    raw_file: str
    dt_s: float  # the fixture's sample interval
    expectation: Expectation
    window: tuple[int, int] | None = None  # samples of the source kept
    hold: str = "zoh"
    deg_per_unit: float | None = None  # None: scaled to ANGLE_SPAN_DEG
    kpa_per_unit: float | None = None
    u_ref: float | None = None  # None: the mean (an operating point, as Silverbox's)
    y_ref: float | None = None
    units: tuple[str, str] = ("u", "y")
    notes: list[str] = field(default_factory=list)


def _negative(control: str, reason: str) -> Expectation:
    return Expectation("negative_control", None, (), NEGATIVE_VERDICTS, control, reason)


LINEAR_OK = ("consistent", "parameters_only", "unexplained", "insufficient_excitation")

RIGS: tuple[Rig, ...] = (
    Rig("cascaded_tanks", "dataBenchmark.csv", 0.01,
        _negative("outside_library", "Torricelli outflow (√h) of both tanks and the upper tank's "
                  "overflow: neither odd nor even in the library's forms"),
        units=("V (pump)", "V (lower tank level)"),
        notes=["time compressed 400x: the source's Ts = 4 s becomes 10 ms"]),
    Rig("pneumatic_friction_circle", "Circle_2bar.csv", 0.01,
        _negative("no_authority", "the test machine moves the rod; the regulated pressure only "
                  "swings with the motion, so the logged input has no authority over it"),
        window=(0, 3000), kpa_per_unit=100.0, deg_per_unit=1.0, u_ref=0.0, y_ref=0.0,
        units=("bar", "mm"),
        notes=["irregular 10 ms log resampled linearly onto a 10 ms grid; 0-30 s"]),
    Rig("pneumatic_friction_kidney", "Kidney_4bar.csv", 0.01,
        _negative("no_authority", "the same friction test on a kidney-shaped bore at 4 bar"),
        window=(0, 3000), kpa_per_unit=100.0, deg_per_unit=1.0, u_ref=0.0, y_ref=0.0,
        units=("bar", "mm"),
        notes=["irregular 10 ms log resampled linearly onto a 10 ms grid; 0-30 s"]),
    Rig("coupled_drives", "drive.mat", 0.02,
        _negative("outside_library", "the speed sensor cannot tell the direction: the output is "
                  "|speed| of a resonant belt and pulley, a rectifier no library form makes"),
        units=("V", "|speed| (sensor units)"), notes=["native 50 Hz"]),
    Rig("hydraulic_actuator", "actuator.mat", 0.01,
        Expectation("no_library_effect", None, (), LINEAR_OK, "outside_library",
                    "oil pressure behind a valve on a flexible arm: third order and more (the "
                    "source fits it black-box); no dry friction, spring law or delay documented"),
        units=("valve opening", "oil pressure"),
        notes=["the copy stores no sampling interval: a sample is taken as 10 ms"]),
    Rig("ball_beam", "ballbeam.dat", 0.01,
        Expectation("no_library_effect", None, ("coulomb_friction",), LINEAR_OK, None,
                    "a ball rolling on a beam, x'' = (5/7)·g·sin(α): no spring (k ≈ 0), sin α "
                    "linear within 0.02 % at |α| < 0.032 rad; rolling resistance (Coulomb-like) "
                    "is plausible but not documented"),
        units=("rad (beam angle)", "m (ball position)"),
        notes=["time compressed 10x: the source's Ts = 0.1 s becomes 10 ms"]),
    Rig("hair_dryer", "dryer.dat", 0.01,
        Expectation("missing_physics", "dead_time", ("dead_time", "valve_lag"),
                    ("missing_physics", "insufficient_excitation"), None,
                    "air heated by a resistor mesh travels down a tube to the thermocouple: a "
                    "transport delay of 2-3 source samples (Ljung's model, 0.16-0.24 s, 20-30 ms "
                    "here) and the heater's own lag in front (a first-order lag: valve_lag's form)"),
        units=("V (heater)", "V (thermocouple)"),
        notes=["time compressed 8x: the source's Ts = 0.08 s becomes 10 ms"]),
    Rig("flexible_arm", "robotArm.mat", 0.002,
        _negative("outside_library", "the output is the arm's acceleration (no static gain, s² "
                  "in the numerator) through several flexible modes: not a finger's angle"),
        units=("N·m (reaction torque)", "acceleration"),
        notes=["the copy stores no sampling interval: a sample is taken as 2 ms (500 Hz)"]),
    Rig("glass_furnace", "glassfurnace.mat", 0.01,
        _negative("unlogged_input", "one of three furnace inputs logged; the other heater and "
                  "the cooling input also drive the temperature and are left out"),
        units=("normalised heating input 1", "normalised temperature 1"),
        notes=["the copy stores no sampling interval: a sample is taken as 10 ms"]),
)

BY_NAME = {rig.name: rig for rig in RIGS}


def _span_scale(x: FloatArray, span: float) -> float:
    """span/ptp(x) rounded to two significant digits."""
    raw = span / max(float(np.ptp(x)), 1e-12)
    return float(f"{raw:.2g}")


def _minus(name: str, ref: float) -> str:
    if ref == 0.0:
        return name
    return f"({name} {'-' if ref > 0 else '+'} {abs(ref):.6g})"


def recording(rig: Rig, raw_path: Path) -> tuple[Recording, dict[str, float]]:
    raw = sources.LOADERS[rig.name](raw_path)
    u, y = raw.u, raw.y
    if rig.name.startswith("pneumatic_friction"):
        t_src = sources.pneumatic_friction_time_s(raw_path)
        grid = np.arange(0.0, t_src[-1], rig.dt_s)
        u, y = np.interp(grid, t_src, u), np.interp(grid, t_src, y)
    if rig.window is not None:
        u, y = u[rig.window[0]:rig.window[1]], y[rig.window[0]:rig.window[1]]
    u_ref = float(np.mean(u)) if rig.u_ref is None else rig.u_ref
    y_ref = float(np.mean(y)) if rig.y_ref is None else rig.y_ref
    kpa = _span_scale(u, PRESSURE_SPAN_KPA) if rig.kpa_per_unit is None else rig.kpa_per_unit
    deg = _span_scale(y, ANGLE_SPAN_DEG) if rig.deg_per_unit is None else rig.deg_per_unit
    t = np.arange(u.size) * rig.dt_s
    scaling = {"kpa_per_unit": kpa, "deg_per_unit": deg, "u_ref": u_ref, "y_ref": y_ref,
               "fixture_dt_s": rig.dt_s, "source_dt_s": raw.dt_s if raw.dt_s is not None else float("nan")}
    return Recording(t, kpa * (u - u_ref), deg * (y - y_ref)), scaling


def convert(rig: Rig, raw_dir: Path, out: Path) -> dict[str, object]:
    rec, scaling = recording(rig, raw_dir / rig.raw_file)
    max_step = min(rig.dt_s / 2, 5e-3)
    linear = fit_ode(rec, "linear", hold=rig.hold, max_step=max_step, physical=True)
    if linear.n < 0:  # the input acts with the opposite sign: flip it (the fit is the same)
        scaling["kpa_per_unit"] = -scaling["kpa_per_unit"]
        rec = Recording(rec.t, -rec.p, rec.theta_deg)
        linear.n = -linear.n
    held_k = None
    if linear.k <= 1e-6:  # no spring the model can hold: k/A fixed small and positive
        held_k = NO_SPRING_K
        linear = fit_ode(rec, "linear", hold=rig.hold, max_step=max_step, stiffness=held_k,
                         physical=True)
    inertia = float(f"{min(max(0.5 / linear.k, 1e-6), 1.0):.2g}")
    src = sources.SOURCES[rig.name]
    scale_text = (f"angle_deg = {scaling['deg_per_unit']:g}*{_minus('y', scaling['y_ref'])} "
                  f"(y in {rig.units[1]}), pressure_kpa = {scaling['kpa_per_unit']:g}*"
                  f"{_minus('u', scaling['u_ref'])} (u in {rig.units[0]}); " + "; ".join(rig.notes))
    meta = {"source": f"{src.data}; {src.repository} {src.path} @ {src.commit[:12]}",
            "sample_rate_hz": f"{1.0 / rig.dt_s:.6g}", "scaling": scale_text}
    write_csv(out / f"{rig.name}.csv", rec, meta, (".3f", ".4f", ".4f"))
    write_model(out / f"{rig.name}_model.yaml", linear.model(inertia), [
        f"{rig.name}: the nominal model from a linear output-error fit of {rig.name}.csv",
        "(tests/diagnose/real/rigs.py with odefit.py; A chosen, B, k, N = A times the fitted ratios)"])
    exp = rig.expectation
    expected: dict[str, object] = {
        "rig": rig.name, "kind": exp.kind, "effect": exp.effect,
        "acceptable_effects": list(exp.acceptable_effects),
        "acceptable_verdicts": list(exp.acceptable_verdicts), "control": exp.control,
        "reason": exp.reason, "input_hold": rig.hold,
        "linear_fit": fit_summary(linear, inertia), "held_stiffness_k_over_a": held_k,
        "scaling": {**scaling, "inertia_kgm2": inertia, "text": scale_text},
        "source": {"data": src.data, "paper": src.paper, "repository": src.repository,
                   "path": src.path, "commit": src.commit, "licence": src.licence},
    }
    if exp.effect == "dead_time":
        expected["delay_scan"] = delay_scan(rec, rig, max_step)
    (out / f"{rig.name}_expected.json").write_text(json.dumps(expected, indent=2) + "\n")
    return expected


def delay_scan(rec: Recording, rig: Rig, max_step: float, most: int = 4) -> dict[str, object]:
    """The independent estimate of a dead time: the linear fit with the command delayed by
    0..`most` whole samples (each fit started from the previous one), the best delay kept."""
    rows = []
    start = None
    for d in range(most + 1):
        p = np.concatenate([np.full(d, rec.p[0]), rec.p[:rec.p.size - d]])
        fit = fit_ode(Recording(rec.t, p, rec.theta_deg), "linear", start=start, hold=rig.hold,
                      max_step=max_step, physical=True)
        start = np.array([fit.b, fit.k, fit.n, 0.0, fit.theta0, fit.omega0])
        rows.append({"delay_s": d * rig.dt_s, "rmse_deg": fit.rmse_deg})
    best = min(rows, key=lambda row: row["rmse_deg"])
    return {"rows": rows, "delay_s": best["delay_s"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("raw_dir", type=Path)
    parser.add_argument("--only", nargs="*", choices=sorted(BY_NAME))
    parser.add_argument("--out", type=Path, default=HERE)
    args = parser.parse_args(argv)
    for name in args.only or [rig.name for rig in RIGS]:
        expected = convert(BY_NAME[name], args.raw_dir, args.out)
        fit = expected["linear_fit"]
        assert isinstance(fit, dict)
        print(f"{name}: rmse {fit['rmse_deg']:.3f} deg, model {fit['model']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
