"""Public real recordings as `diagnose` fixtures: converter and independent fits.

Usage (the raw files are not in the repository; README.md says where they come from):

    python -m tests.diagnose.real.convert silverbox SNLS80mV.mat [--out DIR]
    python -m tests.diagnose.real.convert emps DATA_EMPS.mat [--out DIR]

Each writes into DIR (default: this folder) `<name>.csv` (a recording in the format of
docs/formats.md §1), `<name>_model.yaml` (the minimal model from a linear output-error fit
done here) and `<name>_expected.json` (the effect the source's physics says is missing, this
module's own estimate of its parameter, the scalings and the provenance).

Nothing here imports `hand_service`: the fits are a separate implementation (odefit.py: an
RK4 output-error fit with the effect's term; and for EMPS also the source's own inverse-model
least squares), so a test can hold `diagnose` against them.

The model is A·θ'' + B·θ' + k·θ + f(θ, θ') = N·p with θ in rad (degrees in the CSV) and p in
kPa. Angle data determine only B/A, k/A, N/A and f/A, so each rig gets a chosen A (below),
and every parameter is A times the normalised value fitted here.
"""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.io import loadmat
from scipy.signal import butter, filtfilt

from tests.diagnose.real.odefit import (
    DEG,
    FloatArray,
    Recording,
    fit_ode,
    fit_summary,
    initial_state,
    read_csv,
    write_csv,
    write_model,
)

HERE = Path(__file__).resolve().parent


# ---------------------------------------------------------------------------------------------
# Silverbox: Duffing oscillator m·ÿ + d·ẏ + k·y + k3·y³ = u (u, y in V).

SILVERBOX_RATE_HZ = 1e7 / 2 ** 14  # 610.35 Hz (the benchmark's technical note)
SILVERBOX_DEG_PER_V = 200.0  # angle_deg = 200·y
SILVERBOX_KPA_PER_V = 500.0  # pressure_kpa = 500·u
SILVERBOX_INERTIA = 2.5e-6  # kg·m², chosen so k ≈ 0.5 N·m/rad (a finger's order)
# V1 is a sampled analog voltage: linear between samples (diagnose --input-hold point)
SILVERBOX_HOLD = "point"
SILVERBOX_ARROW_END = 40700  # the first 40 700 samples: Gaussian noise of growing amplitude
SILVERBOX_CUT = (28500, 40700)  # the last 20 s of it: the largest amplitudes


def load_silverbox(mat: Path) -> tuple[FloatArray, FloatArray]:
    """V1 (input) and V2 (output), offsets removed as the data set's README does."""
    raw = loadmat(str(mat))
    u = np.asarray(raw["V1"], dtype=float).ravel()
    y = np.asarray(raw["V2"], dtype=float).ravel()
    return u - u.mean(), y - y.mean()


def silverbox_recording(u: FloatArray, y: FloatArray, start: int, stop: int) -> Recording:
    t = np.arange(stop - start) / SILVERBOX_RATE_HZ
    return Recording(t, SILVERBOX_KPA_PER_V * u[start:stop], SILVERBOX_DEG_PER_V * y[start:stop])


def convert_silverbox(mat: Path, out: Path) -> dict[str, object]:
    u, y = load_silverbox(mat)
    start, stop = SILVERBOX_CUT
    meta = {"source": "Silverbox benchmark (Wigren & Schoukens 2013), SNLS80mV.mat, samples "
                      f"{start}-{stop - 1} (end of the Gaussian 'arrow' section)",
            "sample_rate_hz": f"{SILVERBOX_RATE_HZ:.7g}",
            "scaling": f"angle_deg = {SILVERBOX_DEG_PER_V:g}*V2, pressure_kpa = {SILVERBOX_KPA_PER_V:g}*V1 "
                       "(V1, V2 in V, means removed)"}
    path = out / "silverbox.csv"
    write_csv(path, silverbox_recording(u, y, start, stop), meta, (".5f", ".4f", ".4f"))
    rec = read_csv(path)  # fit exactly what diagnose will read
    hold = SILVERBOX_HOLD
    linear = fit_ode(rec, "linear", hold=hold)
    cubic = fit_ode(rec, "cubic", start=np.array([linear.b, linear.k, linear.n, 0.0, linear.theta0,
                                                  linear.omega0]), hold=hold)
    zoh = fit_ode(rec, "cubic", start=np.array([cubic.b, cubic.k, cubic.n, cubic.c, cubic.theta0,
                                               cubic.omega0]), hold="zoh")
    a = SILVERBOX_INERTIA
    write_model(out / "silverbox_model.yaml", linear.model(a), [
        "Silverbox: the minimal model from a linear output-error fit of silverbox.csv",
        "(tests/diagnose/real/convert.py; A chosen, B, k, N = A times the fitted ratios)"])
    # cross-check on the whole arrow section (66.7 s, from rest)
    whole = silverbox_recording(u, y, 0, SILVERBOX_ARROW_END)
    whole_cubic = fit_ode(whole, "cubic", start=np.array([cubic.b, cubic.k, cubic.n, cubic.c, 0.0, 0.0]),
                          hold=hold)
    s = SILVERBOX_DEG_PER_V * DEG  # rad per V
    expected = {
        "rig": "silverbox",
        "effect": "cubic_stiffness",
        "param": "k3_nm_per_rad3",
        "value": a * cubic.c,
        "value_std": a * cubic.std.get("c", math.nan),
        "input_hold": hold,
        "how": "output-error least squares (RK4, 0.5 ms steps, command linear between samples) of "
               "[B/A, k/A, N/A, k3/A, θ0, θ'0] on silverbox.csv, times the chosen A",
        "cross_checks": {
            "zoh_hold_k3_nm_per_rad3": a * zoh.c,
            "zoh_hold_rmse_deg": zoh.rmse_deg,
            "whole_arrow_0_40699_k3_nm_per_rad3": a * whole_cubic.c,
            "whole_arrow_rmse_deg": whole_cubic.rmse_deg,
        },
        "linear_fit": fit_summary(linear, a),
        "cubic_fit": fit_summary(cubic, a),
        "scaling": {
            "angle_deg_per_V": SILVERBOX_DEG_PER_V, "pressure_kpa_per_V": SILVERBOX_KPA_PER_V,
            "inertia_kgm2": a,
            "inverse": "d/m = B/A; k/m = k/A; k3/m = (k3_model/A)·s² with s = (π/180)·200 = 3.4907 "
                       "rad/V; 1/m = (N/A)·500/s; so k3/k (1/V²) = k3_model·s²/k_model",
            "k3_over_k_per_V2": cubic.c * s ** 2 / cubic.k,
        },
        "source": SILVERBOX_SOURCE,
    }
    (out / "silverbox_expected.json").write_text(json.dumps(expected, indent=2) + "\n")
    return expected


SILVERBOX_SOURCE = {
    "data": "Silverbox benchmark, SNLS80mV.mat (V1 input, V2 output), www.nonlinearbenchmark.org",
    "paper": "T. Wigren, J. Schoukens, 'Three free data sets for development and benchmarking in "
             "nonlinear system identification', ECC 2013; technical note Uppsala Univ. 2013-006",
    "repository": "github.com/antonior92/sysid-neuralnet",
    "path": "data/SilverboxFiles/SNLS80mV.mat",
    "commit": "8da23c9810f738aececa6058a53e40e9a621e5bc",
    "licence": "repository MIT; the data are the benchmark's, published 'free' for identification "
               "research (no licence text found in the copy), cite Wigren & Schoukens 2013",
}


# ---------------------------------------------------------------------------------------------
# EMPS: M·q'' + Fv·q' + Fc·sign(q') + OF = τ = gtau·vir (q in m, τ in N).

EMPS_DEG_PER_M = 200.0  # angle_deg = 200·q
EMPS_KPA_PER_N = 0.5  # pressure_kpa = 0.5·(τ − OF)
EMPS_INERTIA = 0.01  # kg·m², chosen so Tc ≈ 0.0075 N·m (inside the library's range)
EMPS_DECIMATE = 4  # 1 kHz → 250 Hz: force averaged over each block, position at its start
EMPS_PUBLISHED = {"M_kg": 95.1089, "Fv_Ns_per_m": 203.5034, "Fc_N": 20.3935, "OF_N": -3.1648}


@dataclass(frozen=True)
class Idim:
    """The source's inverse-model least squares: τ = M·q'' + Fv·q' + Fc·sign(q') + OF."""

    M_kg: float
    Fv_Ns_per_m: float
    Fc_N: float
    OF_N: float


def load_emps(mat: Path) -> tuple[FloatArray, FloatArray, FloatArray]:
    raw = loadmat(str(mat))
    t = np.asarray(raw["t"], dtype=float).ravel()
    q = np.asarray(raw["qm"], dtype=float).ravel()
    tau = float(np.asarray(raw["gtau"]).item()) * np.asarray(raw["vir"], dtype=float).ravel()
    return t, tau, q


def emps_idim(t: FloatArray, tau: FloatArray, q: FloatArray) -> Idim:
    """Butterworth (4th order, 100 Hz) zero-phase, central differences, decimation to 50 Hz, LS."""
    h = float(np.median(np.diff(t)))
    b, a = butter(4, 100.0 / (0.5 / h))
    qf = filtfilt(b, a, q)
    dq = np.gradient(qf, h)
    ddq = np.gradient(dq, h)
    rows = slice(50, -50)
    x = np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq)])[rows]
    y = tau[rows]
    # decimate as the source does (anti-alias then keep every 10th sample)
    bd, ad = butter(8, 0.8 / 10)
    x = filtfilt(bd, ad, x, axis=0)[::10]
    y = filtfilt(bd, ad, y)[::10]
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    return Idim(*(float(c) for c in coef))


def emps_recording(t: FloatArray, tau: FloatArray, q: FloatArray, offset_n: float,
                   decimate: int = EMPS_DECIMATE) -> Recording:
    n = (t.size // decimate) * decimate
    force = (tau[:n] - offset_n).reshape(-1, decimate).mean(axis=1)
    return Recording(t[:n:decimate] - t[0], EMPS_KPA_PER_N * force, EMPS_DEG_PER_M * q[:n:decimate])


def convert_emps(mat: Path, out: Path) -> dict[str, object]:
    t, tau, q = load_emps(mat)
    idim = emps_idim(t, tau, q)
    meta = {"source": "EMPS benchmark (Janot, Gautier, Brunot 2019), DATA_EMPS.mat, "
                      f"decimated {EMPS_DECIMATE}x (force averaged per block)",
            "sample_rate_hz": f"{1.0 / (EMPS_DECIMATE * float(np.median(np.diff(t)))):.6g}",
            "scaling": f"angle_deg = {EMPS_DEG_PER_M:g}*qm (m), pressure_kpa = {EMPS_KPA_PER_N:g}*"
                       f"(gtau*vir - OF) (N), OF = {idim.OF_N:.4f} N from the inverse-model fit"}
    path = out / "emps.csv"
    write_csv(path, emps_recording(t, tau, q, idim.OF_N), meta, (".3f", ".3f", ".5f"))
    rec = read_csv(path)
    s = EMPS_DEG_PER_M * DEG  # rad per m
    a = EMPS_INERTIA
    # normalised figures of the inverse model: Fv/M, N/A = s/(M·κ), Tc/A = s·Fc/M
    b_idim, n_idim, c_idim = idim.Fv_Ns_per_m / idim.M_kg, s / idim.M_kg / EMPS_KPA_PER_N, \
        s * idim.Fc_N / idim.M_kg
    th0, om0 = initial_state(rec)  # the axis starts almost at rest (0.007 m/s)
    linear = fit_ode(rec, "linear", start=np.array([b_idim, 1e-2, n_idim, 0.0, th0, om0]),
                     free_initial=False)
    no_spring = fit_ode(rec, "coulomb", start=np.array([b_idim, 0.0, n_idim, c_idim, th0, om0]),
                        free_initial=False, stiffness=0.0)
    with_spring = fit_ode(rec, "coulomb", start=np.array([b_idim, linear.k, n_idim, c_idim, th0, om0]),
                          free_initial=False)
    write_model(out / "emps_model.yaml", linear.model(a), [
        "EMPS: the minimal model from a linear output-error fit of emps.csv",
        "(tests/diagnose/real/convert.py; A chosen, B, k, N = A times the fitted ratios)"])
    expected = {
        "rig": "emps",
        "effect": "coulomb_friction",
        "param": "torque_nm",
        "value": a * c_idim,
        "input_hold": "zoh",
        "how": "the source's inverse-model least squares (Script_IDIM_LS.m redone here: 4th-order "
               "100 Hz Butterworth zero-phase, central differences, decimation, LS on "
               "[q'', q', sign(q'), 1]) at 1 kHz; Tc = A·s·Fc/M with s = 3.4907 rad/m",
        "cross_checks": {
            "published_torque_nm": a * s * EMPS_PUBLISHED["Fc_N"] / EMPS_PUBLISHED["M_kg"],
            "output_error_no_spring_torque_nm": a * no_spring.c,
            "output_error_no_spring_rmse_deg": no_spring.rmse_deg,
            "output_error_free_stiffness_torque_nm": a * with_spring.c,
            "output_error_free_stiffness_k_nm_per_rad": a * with_spring.k,
            "output_error_free_stiffness_rmse_deg": with_spring.rmse_deg,
            "idim_ls": asdict(idim),
            "published": EMPS_PUBLISHED,
        },
        "linear_fit": fit_summary(linear, a),
        "coulomb_fit_no_spring": fit_summary(no_spring, a),
        "coulomb_fit_free_stiffness": fit_summary(with_spring, a),
        "scaling": {
            "angle_deg_per_m": EMPS_DEG_PER_M, "pressure_kpa_per_N": EMPS_KPA_PER_N,
            "inertia_kgm2": a, "force_offset_removed_N": idim.OF_N, "decimation": EMPS_DECIMATE,
            "inverse": "with s = (π/180)·200 = 3.4907 rad/m and κ = 0.5 kPa/N: Fv/M = B/A, "
                       "Fc/M = (Tc/A)/s, 1/M = (N/A)·κ/s; so M (kg) = A·s/(κ·N), Fv (N·s/m) = "
                       "B·s/(κ·N), Fc (N) = Tc/(κ·N)",
        },
        "source": EMPS_SOURCE,
    }
    (out / "emps_expected.json").write_text(json.dumps(expected, indent=2) + "\n")
    return expected


EMPS_SOURCE = {
    "data": "EMPS benchmark, DATA_EMPS.mat (t, qm, qg, vir, gtau, kp, kv), www.nonlinearbenchmark.org",
    "paper": "A. Janot, M. Gautier, M. Brunot, 'Data set and reference models of EMPS', Workshop on "
             "Nonlinear System Identification Benchmarks, Eindhoven, 2019",
    "repository": "github.com/forgi86/sysid-neural-continuous",
    "path": "examples/EMPS/data/DATA_EMPS.mat",
    "commit": "956aa7ecd73061b0321c6f6098d74c9e4a7ce67a",
    "licence": "repository Apache-2.0; the data are the benchmark's, published free for identification "
               "research (no licence text in the archive), cite Janot et al. 2019",
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rig", choices=["silverbox", "emps"])
    parser.add_argument("mat", type=Path, help="SNLS80mV.mat (silverbox) or DATA_EMPS.mat (emps)")
    parser.add_argument("--out", type=Path, default=HERE)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    convert = convert_silverbox if args.rig == "silverbox" else convert_emps
    expected = convert(args.mat, args.out)
    print(json.dumps({k: expected.get(k) for k in ("rig", "effect", "param", "value", "input_hold",
                                                    "cross_checks")}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
