"""What `replicate` found: its options, the result and its JSON, and the markdown tables it
prints (Table 1, Table 2, the force test, and what the lab measured for the controller)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.config.effects import effect_value
from hand_service.config.profile import Profile
from hand_service.identification.measured_hand import MeasuredFinger
from hand_service.replicate.force_test import CONTACT_ANGLE_DEG, ForceRun
from hand_service.replicate.tracking import TrackingRun, Tuning
from hand_service.version import software_version

# The paper's Table 1 (k in N·m/rad, B in N·m·s/rad; averages of 10 trials) and Table 2
# (RMSE and max error in deg), as printed (docs/physics.md §2 and §5).
PAPER_LDM = {"thumb": (0.6541, 0.0011), "index": (0.570, 0.0031), "middle": (0.5778, 0.00127),
             "ring": (0.5069, 0.00178), "little": (0.5886, 0.0011224)}
PAPER_POSITION = {"ff_pid_rmse_deg_mean": 2.37, "ff_pid_max_error_deg_mean": 4.37,
                  "pid_rmse_deg_mean": 16.51, "pid_max_error_deg_mean": 20.38}
PAPER_FORCE = {"rmse_n": 0.324, "max_error_n": 0.58}


@dataclass
class Options:
    profile: Path | None = None
    trials_per_finger: int = 10
    periods: int = 10
    quick: bool = False
    seed: int = 1
    trials_dir: Path | None = None

    @classmethod
    def quick_run(cls, **changes: Any) -> Options:
        """A small run for tests: 3 trials a finger, 3 periods, a coarse PID search."""
        return cls(**{"trials_per_finger": 3, "periods": 3, "quick": True, **changes})


@dataclass
class Result:
    options: Options
    truth: Profile
    controller: Profile
    measured: list[MeasuredFinger]
    ff_pid: TrackingRun
    pid: TrackingRun
    tuning: Tuning
    force: ForceRun
    seconds: float

    @property
    def fingers(self) -> list[str]:
        return self.truth.finger_names

    def ldm_json(self) -> dict[str, Any]:
        out = {}
        for m, truth in zip(self.measured, self.truth.fingers, strict=True):
            paper = PAPER_LDM.get(m.name, (None, None))
            true_k, true_b = truth.model.stiffness_nm_per_rad, truth.model.damping_nms_per_rad

            def worst_pct(fit: Any, key: str, true: float) -> float:
                errors = [100 * (t.to_json()[key] / true - 1) for t in fit.trials]
                return float(max(errors, key=abs))

            out[m.name] = {
                "stiffness_nm_per_rad": m.identified.stiffness_nm_per_rad,
                "damping_nms_per_rad": m.identified.damping_nms_per_rad,
                "paper_stiffness_nm_per_rad": paper[0], "paper_damping_nms_per_rad": paper[1],
                "stiffness_std_nm_per_rad": m.identified.std("stiffness_nm_per_rad"),
                "damping_std_nms_per_rad": m.identified.std("damping_nms_per_rad"),
                "true_stiffness_nm_per_rad": true_k, "true_damping_nms_per_rad": true_b,
                "stiffness_error_pct": 100 * (m.identified.stiffness_nm_per_rad / true_k - 1),
                "damping_error_pct": 100 * (m.identified.damping_nms_per_rad / true_b - 1),
                "two_peak_stiffness_nm_per_rad": m.two_peak.stiffness_nm_per_rad,
                "two_peak_damping_nms_per_rad": m.two_peak.damping_nms_per_rad,
                "two_peak_stiffness_error_pct": 100 * (m.two_peak.stiffness_nm_per_rad / true_k - 1),
                "two_peak_damping_error_pct": 100 * (m.two_peak.damping_nms_per_rad / true_b - 1),
                "worst_trial_stiffness_error_pct": worst_pct(m.identified, "stiffness_nm_per_rad", true_k),
                "worst_trial_damping_error_pct": worst_pct(m.identified, "damping_nms_per_rad", true_b),
                "two_peak_worst_trial_stiffness_error_pct":
                    worst_pct(m.two_peak, "stiffness_nm_per_rad", true_k),
                "two_peak_worst_trial_damping_error_pct":
                    worst_pct(m.two_peak, "damping_nms_per_rad", true_b),
                "trials": len(m.identified.trials)}
        return out

    def position_json(self) -> dict[str, Any]:
        fingers = {name: {"ff_pid_rmse_deg": float(self.ff_pid.rmse_deg[i]),
                          "ff_pid_max_error_deg": float(self.ff_pid.max_error_deg[i]),
                          "pid_rmse_deg": float(self.pid.rmse_deg[i]),
                          "pid_max_error_deg": float(self.pid.max_error_deg[i]),
                          "pid_gains": self.tuning.gains_of(i)}
                   for i, name in enumerate(self.fingers)}
        return {"ff_pid_rmse_deg_mean": float(self.ff_pid.rmse_deg.mean()),
                "ff_pid_max_error_deg_mean": float(self.ff_pid.max_error_deg.mean()),
                "pid_rmse_deg_mean": float(self.pid.rmse_deg.mean()),
                "pid_max_error_deg_mean": float(self.pid.max_error_deg.mean()),
                "pid_over_ff_pid_rmse": float(self.pid.rmse_deg.mean() / self.ff_pid.rmse_deg.mean()),
                "fingers": fingers, "periods": self.options.periods, "periods_left_out": 1,
                "pid_tuning_evaluations": self.tuning.evaluations, "paper": PAPER_POSITION}

    def force_json(self) -> dict[str, Any]:
        rmse, worst, span = self.force.rmse_n, self.force.max_error_n, self.force.true_force_span_n
        return {"rmse_n": float(rmse.mean()), "max_error_n": float(worst.mean()),
                "max_error_n_worst": float(worst.max()), "contact_angle_deg": CONTACT_ANGLE_DEG,
                "fingers": {name: {"rmse_n": float(rmse[i]), "max_error_n": float(worst[i]),
                                   "true_force_min_n": float(span[i, 0]),
                                   "true_force_max_n": float(span[i, 1]),
                                   "samples": int(self.force.evaluated[:, i].sum())}
                            for i, name in enumerate(self.fingers)},
                "paper": PAPER_FORCE}

    def to_json(self) -> dict[str, Any]:
        return {"ldm": self.ldm_json(), "position": self.position_json(), "force": self.force_json(),
                "measured": {m.name: m.to_json() for m in self.measured},
                "settings": {"profile": str(self.truth.path), "seed": self.options.seed,
                             "trials_per_finger": self.options.trials_per_finger, "quick": self.options.quick,
                             "sensor_noise_deg": self.truth.simulation["sensor_noise_deg"],
                             "software": software_version(), "seconds": self.seconds}}

    def tables(self) -> str:
        """The markdown tables `replicate` prints."""
        return markdown(self)



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
        f"{result.truth.control.rate_hz:g} Hz). "
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
