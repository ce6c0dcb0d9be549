"""The markdown tables `replicate` prints: Table 1, Table 2, the force test, and what the
lab measured for the controller."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hand_service.effects import effect_value

if TYPE_CHECKING:
    from hand_service.replicate import Result


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def ldm_table(result: Result) -> str:
    rows = []
    for name, v in result.ldm_json().items():
        rows.append([name, f"{v['stiffness_nm_per_rad']:.4f}", f"{v['paper_stiffness_nm_per_rad']}",
                     f"{v['damping_nms_per_rad']:.6f}", f"{v['paper_damping_nms_per_rad']}",
                     f"{v['stiffness_error_pct']:+.2f} / {v['damping_error_pct']:+.2f}",
                     f"{v['worst_trial_stiffness_error_pct']:+.2f} / "
                     f"{v['worst_trial_damping_error_pct']:+.2f}",
                     f"{v['two_peak_stiffness_error_pct']:+.1f} / {v['two_peak_damping_error_pct']:+.1f}",
                     f"{v['two_peak_worst_trial_stiffness_error_pct']:+.1f} / "
                     f"{v['two_peak_worst_trial_damping_error_pct']:+.1f}"])
    return _table(["finger", "k (N·m/rad)", "paper k", "B (N·m·s/rad)", "paper B", "k / B error (%)",
                   "worst trial (%)", "two-peak k / B error (%)", "two-peak worst trial (%)"], rows)


def position_table(result: Result) -> str:
    p = result.position_json()
    rows = [[name, f"{v['ff_pid_rmse_deg']:.2f}", f"{v['ff_pid_max_error_deg']:.2f}",
             f"{v['pid_rmse_deg']:.2f}", f"{v['pid_max_error_deg']:.2f}"] for name, v in p["fingers"].items()]
    rows.append(["**mean**", f"{p['ff_pid_rmse_deg_mean']:.2f}", f"{p['ff_pid_max_error_deg_mean']:.2f}",
                 f"{p['pid_rmse_deg_mean']:.2f}", f"{p['pid_max_error_deg_mean']:.2f}"])
    paper = p["paper"]
    rows.append(["paper (mean)", f"{paper['ff_pid_rmse_deg_mean']}", f"{paper['ff_pid_max_error_deg_mean']}",
                 f"{paper['pid_rmse_deg_mean']}", f"{paper['pid_max_error_deg_mean']}"])
    return _table(["finger", "FF+PID RMSE (deg)", "FF+PID max (deg)", "PID RMSE (deg)", "PID max (deg)"],
                  rows)


def gains_table(result: Result) -> str:
    p = result.position_json()
    rows = [[name, *(f"{v['pid_gains'][key]:.4g}" for key in ("kp_kpa_per_deg", "ki_kpa_per_deg_s",
                                                             "kd_kpa_s_per_deg", "derivative_cutoff_hz"))]
            for name, v in p["fingers"].items()]
    return _table(["finger (PID alone, tuned)", "kp (kPa/deg)", "ki (kPa/(deg·s))", "kd (kPa·s/deg)",
                   "D filter (Hz)"], rows)


def force_table(result: Result) -> str:
    f = result.force_json()
    rows = [[name, f"{v['rmse_n']:.3f}", f"{v['max_error_n']:.3f}",
             f"{v['true_force_min_n']:.2f}–{v['true_force_max_n']:.2f}", str(v["samples"])]
            for name, v in f["fingers"].items()]
    rows.append(["**mean**", f"{f['rmse_n']:.3f}", f"{f['max_error_n']:.3f}", "", ""])
    rows.append(["paper", f"{f['paper']['rmse_n']}", f"{f['paper']['max_error_n']}", "", ""])
    return _table(["finger", "F_est RMSE (N)", "F_est max error (N)", "true force span (N)", "samples"], rows)


def measured_table(result: Result) -> str:
    rows = []
    for m, truth in zip(result.measured, result.truth.fingers, strict=True):
        t = truth.model
        true_lag_ms = 1000 * effect_value(t.effects, "valve_lag")
        true_delay_ms = 1000 * effect_value(t.effects, "dead_time")
        rows.append([m.name, f"{m.model.pressure_gain_nm_per_kpa:.5g} ({t.pressure_gain_nm_per_kpa:.5g})",
                     f"{1000 * m.valve.tau_s:.2f} ({true_lag_ms:.0f})",
                     f"{1000 * m.valve.delay_s:.2f} ({true_delay_ms:.0f})",
                     f"{m.sensor.gain_deg_per_mv:.5g} ({truth.sensor_gain_deg_per_mv:.5g})"])
    return _table(["finger", "N (N·m/kPa), measured (truth)", "valve lag (ms)", "dead time (ms)",
                   "sensor gain (deg/mV)"], rows)


def markdown(result: Result) -> str:
    o = result.options
    return "\n\n".join([
        f"### Table 1: LDM stiffness and damping ({o.trials_per_finger} simulated releases a finger, "
        f"{result.truth.simulation['sensor_noise_deg']:g} deg noise, "
        f"{result.truth.control['rate_hz']:g} Hz). "
        "Errors are against the simulator's truth (the paper's values); k and B by the default "
        "damped-sine fit, then by the paper's two-peak recipe on the same trials.",
        ldm_table(result),
        "### What else the lab measured for the controller (truth in brackets)",
        measured_table(result),
        f"### Table 2: tracking 45·(1 − cos(2πt/0.75 s)), {o.periods} periods, the first left out",
        position_table(result),
        gains_table(result),
        "### Force estimate: the finger at 90° against an object, the true force ramped 0 → 2 N",
        force_table(result),
    ])


__all__ = ["force_table", "gains_table", "ldm_table", "markdown", "measured_table", "position_table"]
