"""Impedance mode against frequency: the rendered stiffness and damping of one finger under
a small sinusoidal push, with the controller's model exact or ±5 % off.

    python -m hand_service.pinch.bode [--finger index] [--share 1.0] [--plot PATH] [--quick]
                                      [--plant model|mismatched|mismatched-even-valves]
                                      [--calibrate | --diagnose]
                                      [--amplitude-deg 2] [--reference-deg 80] [--tare]
                                      [--errors-last] [--span] [--frequency HZ ...]

A probe fixed to the force point (hand_service.pinch.compliance.closed_loop's push: it
pushes and pulls, so the finger cannot leave it) pushes the finger open with a
sinusoidal force of K·AMPLITUDE_DEG at one frequency at a time, about the 80° reference.
The finger is the PRBM (--plant model) or the pinch's mismatched plant (hand_service.
pinch.mismatch.PAPER_MISMATCH; the probe then acts at the drifting contact point).
Over whole periods after the settling, the probe's force and the true angle are each
fitted with a sinusoid at that frequency (least squares, a lock-in): their complex ratio
Z = F / (θ_ref − θ) (N/deg) is the rendered impedance; Re Z the stiffness, Im Z / ω the
damping. The finger's own inertia and damping are in it, as they are for a real probe.
Model errors (`ERRORS`): the controller's joint stiffness k and pressure gain N each
5 % up or down, the four corners; with --calibrate the lab's `calibrate sensor` and
`calibrate gain` then run on the plant (identify_on_plant), which measures N again for
the erroneous k: the free sweep's angle per pressure fixes the ratio N/k, so only k's
error remains (the table's "k, N in use"). With --diagnose the lab then fits its valve
(`calibrate valve`) and runs `diagnose` on a steps recording of the finger, and the
controller runs the model diagnose writes: its refit k, B, N and the effects it names
(hand_service.pinch.lab_diagnose; the table gives its verdict and effects); diagnose's
refit then takes k's and N's errors away, which --errors-last puts back on the model it
writes. The plant
mismatched-even-valves is the mismatched plant with valves that vent as fast as they fill.
Prints one markdown table per finger: per frequency
and model error, the stiffness's error against the set K (%) and the damping
(N·s/deg), "saturated" where the chamber reached 0 or the finger's limit (the valve, not
the impedance law, then sets the stiffness); with --plot, the Bode plot (|Z|, its phase
and the stiffness's error) to PATH.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import Profile, load_profile
from hand_service.identification.span import apply_span
from hand_service.pinch.compliance import SPAN_LOAD_DEG, closed_loop, free_tare, loaded_span
from hand_service.pinch.lab_diagnose import EVEN_VALVES, LabDiagnosis, diagnosed_controller
from hand_service.pinch.mismatch import NONE, PLANTS, Mismatch, identify_on_plant

AMPLITUDE_DEG = 2.0
REFERENCE_DEG = 80.0
SETTLE_S = 3.0
FREQUENCIES_HZ = (0.1, 0.2, 0.5, 1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0)
ERRORS = ((0.0, 0.0), (5.0, 5.0), (-5.0, -5.0), (5.0, -5.0), (-5.0, 5.0))  # (k %, N %)
DAMPING_N_S_PER_DEG = 0.0003  # as the push tests (docs/replicate.md), well inside D_max
TOLERANCE = 0.10
SATURATION_MARGIN_KPA = 1.0
BODE_PLANTS = {**PLANTS, "mismatched-even-valves": EVEN_VALVES}  # the last: diagnose's ablation


def with_errors(controller: Profile, stiffness_pct: float, gain_pct: float) -> Profile:
    """The controller's profile with every finger's k and N off by these percentages."""
    fingers = [dataclasses.replace(f, model=dataclasses.replace(
        f.model, stiffness_nm_per_rad=f.model.stiffness_nm_per_rad * (1.0 + stiffness_pct / 100.0),
        pressure_gain_nm_per_kpa=f.model.pressure_gain_nm_per_kpa * (1.0 + gain_pct / 100.0)))
        for f in controller.fingers]
    return dataclasses.replace(controller, fingers=fingers)


def quasi_static_ratio(share_of_limit: float, stiffness_pct: float, gain_pct: float) -> float:
    """The measured over the set stiffness at equilibrium: with N p = k θ + r F on the
    plant, the estimate (N' p − k' θ) / r is F (1 + e_N) + (e_N − e_k) k θ / r, so the
    finger renders (K + 2 (e_N − e_k) K_max) / (1 + e_N) (K_max = 0.5 k / (r·180/π))."""
    e_k, e_n = stiffness_pct / 100.0, gain_pct / 100.0
    return (1.0 + 2.0 * (e_n - e_k) / share_of_limit) / (1.0 + e_n)


def loop_in_phase_share(width_deg: float, amplitude_deg: float) -> float:
    """The in-phase stiffness of a joint friction, as a share of the joint's k: the plant's
    silicone loop (mismatch.Hysteresis: the torque k (θ − z), z a play of half-width w, a
    Jenkins element) under θ = A cos ωt has the first harmonic k·A·(ψ − sin ψ cos ψ)/π in
    phase, cos ψ = 1 − 2w/A (ψ the phase where it yields; all of k while A ≤ w). Unseen by
    the estimate, it adds this share times k_F/K = 2/share to the rendered stiffness."""
    if amplitude_deg <= width_deg:
        return 1.0
    psi = math.acos(1.0 - 2.0 * width_deg / amplitude_deg)
    return (psi - math.sin(psi) * math.cos(psi)) / math.pi


def _phasor(t_s: np.ndarray, signal: np.ndarray, omega: float) -> complex:
    """The least-squares sinusoid at omega through signal (with an offset): a + b sin + c cos,
    as the complex amplitude b + i c (sin as the reference phase)."""
    basis = np.column_stack([np.ones_like(t_s), np.sin(omega * t_s), np.cos(omega * t_s)])
    _, b, c = np.linalg.lstsq(basis, signal, rcond=None)[0]
    return complex(b, c)


@dataclass
class Point:
    frequency_hz: float
    impedance_n_per_deg: complex
    saturated: bool = False  # the chamber reached 0 or the finger's limit: the valve, not the law

    @property
    def stiffness_n_per_deg(self) -> float:
        return self.impedance_n_per_deg.real

    @property
    def damping_n_s_per_deg(self) -> float:
        return self.impedance_n_per_deg.imag / (2.0 * math.pi * self.frequency_hz)


def rendered(truth: Profile, controller: Profile, finger: str, stiffness_n_per_deg: float,
             frequency_hz: float, seed: int = 1, periods: int | None = None, mismatch: Mismatch = NONE,
             amplitude_deg: float = AMPLITUDE_DEG, reference_deg: float = REFERENCE_DEG) -> Point:
    """The rendered impedance at one frequency (see the module's docstring)."""
    omega = 2.0 * math.pi * frequency_hz
    count = periods or max(3, math.ceil(4.0 * frequency_hz))
    duration_s = SETTLE_S + count / frequency_hz
    amplitude_n = stiffness_n_per_deg * amplitude_deg

    loop = closed_loop(truth, finger, stiffness_n_per_deg, DAMPING_N_S_PER_DEG, duration_s,
                       lambda _: reference_deg, lambda _: None, seed, controller,
                       push_n=lambda t_s: amplitude_n * math.sin(omega * t_s), mismatch=mismatch)
    t_s = np.arange(loop.angle_deg.size) / truth.control.rate_hz
    last = t_s >= duration_s - count / frequency_hz
    shortfall = _phasor(t_s[last], reference_deg - loop.angle_deg[last], omega)
    force = _phasor(t_s[last], loop.force_n[last], omega)
    chamber = loop.chamber_kpa[last]
    limit_kpa = truth.finger(finger).pressure_max_kpa
    saturated = bool(np.any(chamber < SATURATION_MARGIN_KPA)
                     or np.any(chamber > limit_kpa - SATURATION_MARGIN_KPA))
    return Point(frequency_hz, force / shortfall, saturated)


def sweep(truth: Profile, controller: Profile, finger: str, stiffness_n_per_deg: float,
          frequencies_hz: tuple[float, ...] = FREQUENCIES_HZ, seed: int = 1, mismatch: Mismatch = NONE,
          amplitude_deg: float = AMPLITUDE_DEG, reference_deg: float = REFERENCE_DEG) -> list[Point]:
    return [rendered(truth, controller, finger, stiffness_n_per_deg, f, seed, mismatch=mismatch,
                     amplitude_deg=amplitude_deg, reference_deg=reference_deg) for f in frequencies_hz]


def bandwidth_hz(points: list[Point], set_n_per_deg: float, tolerance: float = TOLERANCE) -> float:
    """The highest frequency up to which every point's stiffness is within tolerance of the
    set value, unsaturated (0 if the lowest is not)."""
    top = 0.0
    for p in points:
        if p.saturated or abs(p.stiffness_n_per_deg / set_n_per_deg - 1.0) > tolerance:
            break
        top = p.frequency_hz
    return top


def bode_figure(curves: dict[str, list[Point]], set_n_per_deg: float, title: str, path: Path) -> Path:
    from hand_service.identification.plots import pyplot, save

    plt = pyplot()
    fig, (top, middle, bottom) = plt.subplots(3, 1, figsize=(6.5, 8.0), sharex=True)
    for label, points in curves.items():
        f = [p.frequency_hz for p in points]
        z = np.array([p.impedance_n_per_deg for p in points])
        top.loglog(f, np.abs(z), marker="o", label=label)
        middle.semilogx(f, np.degrees(np.angle(z)), marker="o")
        error_pct = [100.0 * (p.stiffness_n_per_deg / set_n_per_deg - 1.0) for p in points]
        bottom.semilogx(f, error_pct, marker="o")
    top.axhline(set_n_per_deg, color="k", lw=0.8, ls="--")
    top.set_ylabel("|F / (θ_ref − θ)| (N/deg)")
    top.set_title("\n".join(textwrap.fill(line, 100) for line in title.splitlines()), fontsize=8)
    top.legend(fontsize=7)
    middle.set_ylabel("phase (deg)")
    for level in (-100.0 * TOLERANCE, 100.0 * TOLERANCE):
        bottom.axhline(level, color="k", lw=0.8, ls="--")
    bottom.set_ylabel("Re Z against K (%)")
    bottom.set_xlabel("frequency (Hz)")
    return save(fig, path)


@dataclass
class Corner:
    """The controller of one model-error corner, its k's and N's error against the truth's
    (%), and what the lab's diagnose said of the finger (None without --diagnose)."""

    controller: Profile
    stiffness_pct: float
    gain_pct: float
    diagnosis: LabDiagnosis | None = None
    lever_pct: float = 0.0  # the lever arm in use against the model's r (the span's)

    def said(self) -> str:
        d = self.diagnosis
        return "" if d is None else f"{d.diagnosis.verdict}: {d.effects_said()}"


def span_stiffness(controller: Profile, finger: str, set_n_per_deg: float | None) -> float:
    """The K (N/deg) the span is made at: the one the finger will render, else its K_max.
    After the tare a load L held at K reads s·L + ε·(L/K)/r, ε the estimate's error in the
    finger's spring about the reference (N·m/deg) and s the lever's scale: the span's
    reading is s + ε/(r K), so a lever spanned at K renders K there, while one spanned at
    K_max leaves ε/(r K)·(1 − K/K_max) of K (2/share − 2 times ε/k: 18 ε/k at 0.1 K_max)."""
    if set_n_per_deg is not None:
        return set_n_per_deg
    return gain_limits(controller.finger(finger).model)[0]


def corner_controller(truth: Profile, finger: str, stiffness_pct: float, gain_pct: float,
                      mismatch: Mismatch, calibrate: bool, seed: int, diagnosed: bool = False,
                      errors_last: bool = False, tare_n_per_deg: float | None = None,
                      reference_deg: float = REFERENCE_DEG, span: bool = False) -> Corner:
    """The controller with k and N off by these percentages; with calibrate, the lab's
    `calibrate sensor` and `calibrate gain` then run on the plant (N measured again for
    that k); with diagnosed, after those the lab's `calibrate valve` and `diagnose` on a
    steps recording of the finger, the controller's model the one diagnose writes
    (hand_service.pinch.lab_diagnose); with errors_last the errors are put on the model
    diagnose wrote instead (its effects kept), not on the lab's starting model; with
    tare_n_per_deg, last, the estimate's free-motion tare in impedance mode at that K about
    reference_deg (compliance.free_tare), which sets N again; with span, after it, the
    estimate's span under a known load (compliance.loaded_span) made at the K it renders
    (tare_n_per_deg; without it the controller's own K_max) with a load of that K times
    SPAN_LOAD_DEG, which sets the lever arm: what the model misses of the finger's spring
    about the reference reads as a share of the load that grows as 1/K (span_stiffness)."""
    controller = truth if errors_last and diagnosed else with_errors(truth, stiffness_pct, gain_pct)
    if calibrate or diagnosed:
        with tempfile.TemporaryDirectory(prefix="pinch-bode-") as scratch:
            controller = identify_on_plant(truth, controller, mismatch, seed, Path(scratch))
    diagnosis = None
    if diagnosed:
        controller, (diagnosis,) = diagnosed_controller(truth, controller, mismatch, seed, [finger])
        if errors_last:
            controller = with_errors(controller, stiffness_pct, gain_pct)
    if tare_n_per_deg is not None:
        controller = free_tare(truth, controller, finger, tare_n_per_deg, reference_deg, seed, mismatch)
    if span:
        k_span = span_stiffness(controller, finger, tare_n_per_deg)
        measured = loaded_span(truth, controller, finger, k_span, k_span * SPAN_LOAD_DEG, reference_deg, seed,
                               mismatch)
        controller = apply_span(controller, measured)
    mine, true = controller.finger(finger).model, truth.finger(finger).model
    return Corner(controller, 100.0 * (mine.stiffness_nm_per_rad / true.stiffness_nm_per_rad - 1.0),
                  100.0 * (mine.pressure_gain_nm_per_kpa / true.pressure_gain_nm_per_kpa - 1.0), diagnosis,
                  100.0 * (mine.lever_arm_m / true.lever_arm_m - 1.0))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.bode", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--finger", action="append", help="a finger (repeatable; default index)")
    parser.add_argument("--share", type=float, default=1.0,
                        help="K as a share of the finger's K_max (default 1)")
    parser.add_argument("--plot", type=Path, help="write the Bode plot of the first finger here (.png)")
    parser.add_argument("--quick", action="store_true", help="three frequencies, no model error")
    parser.add_argument("--frequency", type=float, action="append",
                        help="a push frequency in Hz (repeatable; default "
                             + ", ".join(f"{f:g}" for f in FREQUENCIES_HZ) + ")")
    parser.add_argument("--plant", choices=sorted(BODE_PLANTS), default="model",
                        help="the PRBM (model, default), the pinch's mismatched plant, or that plant "
                             "with valves that vent as fast as they fill")
    parser.add_argument("--calibrate", action="store_true",
                        help="after the model error, the lab's calibrate sensor and gain on the plant")
    parser.add_argument("--diagnose", action="store_true",
                        help="after calibrate sensor and gain (implied), the lab's calibrate valve and "
                             "diagnose on a steps recording; the controller runs the model diagnose writes")
    parser.add_argument("--errors-last", action="store_true",
                        help="with --diagnose, put the k and N errors on the model diagnose writes "
                             "(its effects kept) instead of on the lab's starting model")
    parser.add_argument("--tare", action="store_true",
                        help="last, tare the force estimate on the free finger at the reference "
                             "(hand_service.identification.tare), as the lab does before contact")
    parser.add_argument("--span", action="store_true",
                        help="after the tare (implied), the estimate's span under a known load at the pad, "
                             "made at the set K (hand_service.identification.span), which sets the lever arm")
    parser.add_argument("--amplitude-deg", type=float, default=AMPLITUDE_DEG,
                        help=f"the push's amplitude as K times this angle (default {AMPLITUDE_DEG:g})")
    parser.add_argument("--reference-deg", type=float, default=REFERENCE_DEG,
                        help=f"the impedance's reference angle (default {REFERENCE_DEG:g})")
    args = parser.parse_args(argv)
    if not 0.0 < args.share <= 1.0:
        parser.error("--share must be above 0 and at most 1")
    if args.amplitude_deg <= 0.0:
        parser.error("--amplitude-deg must be above 0")
    if args.errors_last and not args.diagnose:
        parser.error("--errors-last needs --diagnose")
    truth = load_profile(None)
    mismatch = BODE_PLANTS[args.plant]
    frequencies = (0.1, 1.0, 5.0) if args.quick else FREQUENCIES_HZ
    frequencies = tuple(args.frequency) if args.frequency else frequencies
    errors = ERRORS[:1] if args.quick else ERRORS
    for n, finger in enumerate(args.finger or ["index"]):
        k_set = args.share * gain_limits(truth.finger(finger).model)[0]
        curves = {}
        head = f"{finger}, K = {k_set:.4f} N/deg ({args.share:g} K_max), D = {DAMPING_N_S_PER_DEG:g} N·s/deg"
        lab = ", calibrated and diagnosed" if args.diagnose else ", calibrated" if args.calibrate else ""
        lab += ", the errors on diagnose's model" if args.diagnose and args.errors_last else ""
        lab += ", tared free at the reference" if args.tare or args.span else ""
        lab += ", spanned under a known load" if args.span else ""
        tail = (f"{args.plant} plant{lab}, "
                f"push K·{args.amplitude_deg:g}° about {args.reference_deg:g}°")
        print(f"\n{head}, {tail}: stiffness error against K (%); damping (N·s/deg)\n")
        said = " diagnose's verdict: effects |" if args.diagnose else ""
        print("| model error (k, N) | k, N, r in use | PRBM quasi-static | "
              + " | ".join(f"{f:g} Hz" for f in frequencies) + f" | within 10 % up to |{said}")
        print("| --- | --- | --- |" + " --- |" * len(frequencies) + " --- |" + (" --- |" if said else ""))
        for k_pct, n_pct in errors:
            label = f"k {k_pct:+g} %, N {n_pct:+g} %"
            corner = corner_controller(truth, finger, k_pct, n_pct, mismatch, args.calibrate, seed=1,
                                       diagnosed=args.diagnose, errors_last=args.errors_last,
                                       tare_n_per_deg=k_set if args.tare or args.span else None,
                                       reference_deg=args.reference_deg, span=args.span)
            points = sweep(truth, corner.controller, finger, k_set, frequencies, mismatch=mismatch,
                           amplitude_deg=args.amplitude_deg, reference_deg=args.reference_deg)
            curves[label] = points
            cells = [f"{100 * (p.stiffness_n_per_deg / k_set - 1):+.1f}; {p.damping_n_s_per_deg:.5f}"
                     + (" (saturated)" if p.saturated else "") for p in points]
            top = bandwidth_hz(points, k_set)
            ratio = quasi_static_ratio(args.share, corner.stiffness_pct, corner.gain_pct)
            print(f"| {label} | {corner.stiffness_pct:+.1f} %, {corner.gain_pct:+.1f} %, "
                  f"{corner.lever_pct:+.1f} % | "
                  f"{100 * (ratio - 1):+.1f} | " + " | ".join(cells)
                  + f" | {'none' if top == 0 else f'{top:g} Hz'} |"
                  + (f" {corner.said()} |" if args.diagnose else ""), flush=True)
        if args.plot is not None and n == 0:
            bode_figure(curves, k_set, f"{head}\n{tail}", args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
