"""Figures for identify and calibrate (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hand_service.errors import UserError

if TYPE_CHECKING:
    from hand_service.identification.calibration import GainFit
    from hand_service.identification.identify import IdentifyResult

MAX_TRIAL_PANELS = 12


def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, path: Path) -> Path:
    """Write the figure in the format its suffix names (PNG without one); returns the file."""
    path = Path(path)
    if path.is_dir():
        pyplot().close(fig)
        raise UserError(f"{path}: cannot write: Is a directory")
    if not path.suffix:
        path = path.with_name(path.name + ".png")  # what matplotlib writes: say so
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    except ValueError as exc:  # a suffix matplotlib has no writer for
        raise UserError(f"{path}: cannot write: {exc}") from None
    finally:
        pyplot().close(fig)
    return path


def identify_figure(result: IdentifyResult, path: Path) -> Path:
    """One panel per trial (data, the fitted response, the peaks the method used), and one
    for the decrement drift: amplitude lost per cycle against the amplitude."""
    plt = pyplot()
    trials = result.trials[:MAX_TRIAL_PANELS]
    panels = len(trials) + 1
    columns = min(3, panels)
    rows = math.ceil(panels / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(5.2 * columns, 3.2 * rows), squeeze=False)
    for ax, trial in zip(axes.flat, trials, strict=False):
        fit, estimate, release = trial.fit, trial.estimate, trial.release_s
        t, angle = trial.recording.t_s, trial.recording.angle_deg
        shown = (t >= release - 0.15) & (t <= fit.end_s + 0.15)
        ax.plot(t[shown] - release, angle[shown], ".", ms=3, color="0.35", label="data")
        fine = np.linspace(release, fit.end_s, 2000)
        ax.plot(fine - release, fit.curve_deg(fine), "-", lw=1.0, color="C0",
                label=f"damped sine (RMS {fit.rmse_deg:.2f} deg)")
        if estimate.method != "fit" and estimate.peaks_t_s.size:
            ax.plot(estimate.peaks_t_s - release, estimate.peaks_deg, "o", mfc="none", color="C3",
                    label=f"{estimate.method} peaks")
        ax.axvline(0.0, color="C2", lw=0.8, ls="--", label="release (from the fit)")
        ax.axvline(fit.start_s - release, color="0.6", lw=0.6, ls=":")
        ax.set_title(f"{Path(trial.file).name}: k = {trial.stiffness_nm_per_rad:.4g}, "
                     f"B = {trial.damping_nms_per_rad:.3g}", fontsize=9)
        ax.set_xlabel("time since the release (s)")
        ax.set_ylabel("angle (deg)")
        ax.legend(fontsize=7, loc="upper right")
    drift_ax = axes.flat[len(trials)]
    for trial in result.trials:
        r = trial.cycles.amplitude_deg
        if r.size > 1:
            drift_ax.plot(0.5 * (r[:-1] + r[1:]), r[:-1] - r[1:], "o", ms=3, color="C0")
    if result.drift:
        d = result.drift
        x = np.linspace(0.0, d.high_amplitude_deg * 1.2, 50)
        drift_ax.plot(x, d.loss_fraction_per_cycle * x + d.amplitude_loss_deg_per_cycle, "-", color="C3",
                      label=f"ΔR = {d.loss_fraction_per_cycle:.3f}·R "
                            f"+ {d.amplitude_loss_deg_per_cycle:.2f} deg ({d.kind})")
        drift_ax.legend(fontsize=7)
    drift_ax.set_title("amplitude lost per cycle (viscous: a line through 0)", fontsize=9)
    drift_ax.set_xlabel("cycle amplitude (deg)")
    drift_ax.set_ylabel("loss over the next cycle (deg)")
    for ax in list(axes.flat)[panels:]:
        ax.axis("off")
    fig.suptitle(f"identify ({result.method}): k = {result.stiffness_nm_per_rad:.4g} N·m/rad, "
                 f"B = {result.damping_nms_per_rad:.4g} N·m·s/rad, "
                 f"A = {result.inertia_kgm2:.4g} kg·m² (held)")
    fig.tight_layout()
    return save(fig, path)


def gain_figure(fit: GainFit, path: Path) -> Path:
    """Torque the model needs against the effective pressure, with the fitted line."""
    plt = pyplot()
    fig, (ax, res_ax) = plt.subplots(1, 2, figsize=(11, 4))
    ax.plot(fit.pressure_kpa, fit.torque_nm, ".", ms=2, color="0.4", label="data: model torque at θ")
    p = np.linspace(0.0, float(np.max(fit.pressure_kpa)), 50)
    ax.plot(p, fit.pressure_gain_nm_per_kpa * p + fit.offset_nm, "-", color="C3",
            label=f"N = {fit.pressure_gain_nm_per_kpa:.5g} N·m/kPa (R² {fit.r_squared:.5f})")
    ax.set_xlabel(f"{fit.pressure_column} (kPa)")
    ax.set_ylabel("torque k·θ + effects (N·m)")
    ax.legend(fontsize=8)
    res_ax.plot(fit.pressure_kpa, np.degrees(fit.residual_rad), ".", ms=2, color="C0")
    res_ax.set_xlabel(f"{fit.pressure_column} (kPa)")
    res_ax.set_ylabel("angle residual (deg)")
    res_ax.set_title(f"RMS {fit.rmse_deg:.3f} deg", fontsize=9)
    fig.tight_layout()
    return save(fig, path)


__all__ = ["gain_figure", "identify_figure", "pyplot", "save"]
