"""Sobol indices of the pinch ordering over the parameters the paper does not give.

    python -m hand_service.pinch.sobol [--base-samples 8] [--trials 10] [--seed 1]

The output per object: the paired difference of success rates, force control minus
constant pressure, pooled over the four finger pairs (once-per-object tuning, the default
rule). The parameters and their ranges (PARAMETERS): the pads' stiffness, a factor on
every object's friction, a factor on the finger's torsion (the coin's tilt with force),
the design pinch width (the gap the fingers close over), the closing rate and a factor
on the mismatched plant's sizes (hand_service.pinch.mismatch.PAPER_MISMATCH, with the
lab's calibration run again on it). Saltelli's sampling and Sobol's first-order and
total indices by SALib, N (D + 2) runs for N base samples and D parameters. Prints one
markdown table: per object and parameter, S1 and ST with their 95 % bootstrap half-widths.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from SALib.analyze import sobol as sobol_analyze
from SALib.sample import sobol as sobol_sample

from hand_service.config.profile import Profile
from hand_service.errors import UserError
from hand_service.pinch import plant, trials
from hand_service.pinch.experiment import run_pinch
from hand_service.pinch.mismatch import PAPER_MISMATCH, Mismatch, identify_on_plant
from hand_service.pinch.objects import OBJECT_NAMES, OBJECTS, PAPER_LABELS

# name, low, high (the defaults of docs/replicate.md lie inside)
PARAMETERS: tuple[tuple[str, float, float], ...] = (
    ("pad_stiffness_n_per_m", 1500.0, 4000.0),
    ("friction_factor", 0.7, 1.3),
    ("torsion_factor", 0.5, 2.0),
    ("design_width_m", 0.015, 0.035),
    ("closing_rate_kpa_per_s", 100.0, 400.0),
    ("mismatch_factor", 0.0, 2.0),
)


def problem() -> dict:
    return {"num_vars": len(PARAMETERS), "names": [p[0] for p in PARAMETERS],
            "bounds": [[p[1], p[2]] for p in PARAMETERS]}


@contextmanager
def physics(pad_stiffness_n_per_m: float, torsion_factor: float, design_width_m: float,
            closing_rate_kpa_per_s: float) -> Iterator[None]:
    """The pinch modules' constants set for one run, and put back after it."""
    saved = (plant.PAD_STIFFNESS_N_PER_M, plant.FINGER_SHEAR_MODULUS_PA, trials.DESIGN_WIDTH_M,
             trials.CLOSING_RATE_KPA_PER_S)
    plant.PAD_STIFFNESS_N_PER_M = pad_stiffness_n_per_m
    plant.FINGER_SHEAR_MODULUS_PA = saved[1] * torsion_factor
    trials.DESIGN_WIDTH_M = design_width_m
    trials.CLOSING_RATE_KPA_PER_S = closing_rate_kpa_per_s
    try:
        yield
    finally:
        (plant.PAD_STIFFNESS_N_PER_M, plant.FINGER_SHEAR_MODULUS_PA, trials.DESIGN_WIDTH_M,
         trials.CLOSING_RATE_KPA_PER_S) = saved


def scaled(mismatch: Mismatch, factor: float) -> Mismatch:
    """The mismatch's sizes times factor; the board's valves kept unless factor is 0."""
    return dataclasses.replace(mismatch, stiffening=mismatch.stiffening * factor,
                               lever_drift_per_rad=mismatch.lever_drift_per_rad * factor,
                               sensor_bow_deg=mismatch.sensor_bow_deg * factor,
                               hysteresis_deg=mismatch.hysteresis_deg * factor,
                               valves=mismatch.valves if factor > 0.0 else None)


def evaluate(truth: Profile, controller: Profile, values: np.ndarray, trials_per_cell: int,
             seed: int, workdir: Path) -> np.ndarray:
    """One parameter set: per object (OBJECT_NAMES order) the paired difference."""
    p = dict(zip((q[0] for q in PARAMETERS), values, strict=True))
    mismatch = scaled(PAPER_MISMATCH, p["mismatch_factor"])
    calibrated = identify_on_plant(truth, controller, mismatch, seed, workdir)
    objects = tuple(dataclasses.replace(o, friction=o.friction * p["friction_factor"]) for o in OBJECTS)
    with physics(p["pad_stiffness_n_per_m"], p["torsion_factor"], p["design_width_m"],
                 p["closing_rate_kpa_per_s"]):
        try:
            result = run_pinch(truth, calibrated, trials_per_cell, seed, objects=objects, mismatch=mismatch)
        except UserError:  # a tuning with no window: the ordering is undefined there
            return np.full(len(OBJECT_NAMES), np.nan)
    return np.array([result.paired(name).difference for name in OBJECT_NAMES])


def analyse(outputs: np.ndarray, seed: int) -> list[dict]:
    """Per output column: SALib's S1, S1_conf, ST, ST_conf (NaN rows, where a tuning found
    no window, replaced by the column's mean)."""
    found = []
    for column in outputs.T:
        y = np.where(np.isfinite(column), column, np.nanmean(column))
        found.append(sobol_analyze.analyze(problem(), y, calc_second_order=False, seed=seed))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.sobol", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--base-samples", type=int, default=8, help="N, a power of 2 (default 8)")
    parser.add_argument("--trials", type=int, default=10, help="trials a cell per run (default 10)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    from hand_service.replicate.pinch_run import measured_controller

    truth, controller = measured_controller(None, args.seed, 3)
    samples = sobol_sample.sample(problem(), args.base_samples, calc_second_order=False, seed=args.seed)
    outputs = np.empty((len(samples), len(OBJECT_NAMES)))
    with tempfile.TemporaryDirectory(prefix="pinch-sobol-") as scratch:
        for i, values in enumerate(samples):
            outputs[i] = evaluate(truth, controller, values, args.trials, args.seed, Path(scratch))
            print(f"run {i + 1}/{len(samples)}: {np.round(outputs[i], 3).tolist()}", file=sys.stderr,
                  flush=True)
    print(f"Sobol indices of the paired difference (force minus pressure), {len(samples)} runs "
          f"(N = {args.base_samples}, D = {len(PARAMETERS)}), {args.trials} trials a cell, seed {args.seed}; "
          f"{int(np.sum(~np.isfinite(outputs).all(axis=1)))} runs without a tuning window")
    print()
    print("| object | mean difference | parameter | S1 (±95 %) | ST (±95 %) |")
    print("| --- | --- | --- | --- | --- |")
    for name, got, column in zip(OBJECT_NAMES, analyse(outputs, args.seed), outputs.T, strict=True):
        for k, (parameter, _, _) in enumerate(PARAMETERS):
            first = f"{got['S1'][k]:.2f} ± {got['S1_conf'][k]:.2f}"
            total = f"{got['ST'][k]:.2f} ± {got['ST_conf'][k]:.2f}"
            print(f"| {PAPER_LABELS[name]} | {100 * np.nanmean(column):+.1f} points | {parameter} | "
                  f"{first} | {total} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
