"""The figures of `replicate --plots DIR`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hand_service.identification.plots import identify_figure, pyplot, save

if TYPE_CHECKING:
    from hand_service.replicate.result import Result


def ldm_figure(result: Result, path: Path) -> Path:
    """Per finger, every trial's k and B error against the truth, by both methods."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    names = result.fingers
    for ax, key, label in ((axes[0], "stiffness_nm_per_rad", "k"), (axes[1], "damping_nms_per_rad", "B")):
        for offset, method, color in ((-0.12, "identified", "C0"), (0.12, "two_peak", "C3")):
            for i, (m, truth) in enumerate(zip(result.measured, result.truth.fingers, strict=True)):
                true = getattr(truth.model, key)
                fit = getattr(m, method)
                errors = 100 * (np.array([t.to_json()[key] for t in fit.trials]) / true - 1)
                ax.plot(np.full(errors.size, i + offset), errors, ".", color=color, alpha=0.5)
                legend = "damped-sine fit" if method == "identified" else "two-peak (paper)"
                ax.plot(i + offset, 100 * (fit.mean(key) / true - 1), "_", ms=18, mew=2, color=color,
                        label=legend if i == 0 else None)
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xticks(range(len(names)), names)
        ax.set_ylabel(f"{label} error against the truth (%)")
        ax.set_title(f"{label}: each trial (dots) and the mean of the trials (bar)", fontsize=9)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save(fig, path)


def tracking_figure(result: Result, path: Path, periods_shown: int = 3) -> Path:
    """The last periods of the sweep: reference and true angle, and the error, per finger."""
    plt = pyplot()
    names = result.fingers
    fig, axes = plt.subplots(len(names), 2, figsize=(12, 2.3 * len(names)), squeeze=False, sharex=True)
    run_ff, run_pid = result.ff_pid, result.pid
    shown = run_ff.t_s >= run_ff.t_s[-1] - periods_shown * 0.75
    t = run_ff.t_s[shown]
    for i, name in enumerate(names):
        left, right = axes[i]
        left.plot(t, run_ff.reference_deg[shown], "k--", lw=1.0, label="reference")
        left.plot(t, run_ff.angle_deg[shown, i], "C0", lw=1.0, label="FF+PID")
        left.plot(t, run_pid.angle_deg[shown, i], "C3", lw=1.0, label="PID alone (tuned)")
        left.set_ylabel(f"{name} (deg)")
        right.plot(t, run_ff.angle_deg[shown, i] - run_ff.reference_deg[shown], "C0", lw=1.0,
                   label=f"FF+PID, RMSE {run_ff.rmse_deg[i]:.2f}")
        right.plot(t, run_pid.angle_deg[shown, i] - run_pid.reference_deg[shown], "C3", lw=1.0,
                   label=f"PID, RMSE {run_pid.rmse_deg[i]:.2f}")
        right.axhline(0.0, color="0.5", lw=0.6)
        right.set_ylabel("error (deg)")
        right.legend(fontsize=7, loc="upper right")
        if i == 0:
            left.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time (s)")
    axes[-1, 1].set_xlabel("time (s)")
    fig.suptitle("Table 2: true angle against 45·(1 − cos(2πt/0.75 s)), the last periods")
    fig.tight_layout()
    return save(fig, path)


def force_figure(result: Result, path: Path) -> Path:
    """F_est against the true force over the ramp, per finger, and the error."""
    plt = pyplot()
    run = result.force
    fig, (ax, err_ax) = plt.subplots(1, 2, figsize=(11, 4))
    for i, name in enumerate(result.fingers):
        mask = run.evaluated[:, i]
        true, estimate = run.true_force_n[mask, i], run.estimate_n[mask, i]
        ax.plot(true, estimate, ".", ms=2, color=f"C{i}", label=f"{name}: RMSE {run.rmse_n[i]:.3f} N")
        err_ax.plot(true, estimate - true, ".", ms=2, color=f"C{i}")
    ax.plot([0, 2], [0, 2], "k--", lw=0.8)
    ax.set_xlabel("true force at the force point (N)")
    ax.set_ylabel("estimated normal force (N)")
    ax.legend(fontsize=7)
    err_ax.axhline(0.0, color="0.5", lw=0.8)
    err_ax.set_xlabel("true force (N)")
    err_ax.set_ylabel("estimate − truth (N)")
    fig.suptitle("force estimate (Jᵀ)⁺·(N·p − k·θ) at 90°, against the simulated truth")
    fig.tight_layout()
    return save(fig, path)


def write_plots(result: Result, directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    paths = [ldm_figure(result, directory / "table1_ldm.png"),
             tracking_figure(result, directory / "table2_tracking.png"),
             force_figure(result, directory / "force.png")]
    paths += [identify_figure(m.identified, directory / f"identify_{m.name}.png") for m in result.measured]
    return paths


__all__ = ["force_figure", "ldm_figure", "tracking_figure", "write_plots"]
