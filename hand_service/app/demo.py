"""The demo `make run` shows through the real daemon: the paper's 0 -> 90 deg cosine sweep
on every finger, then a pinch: thumb and index close on simulated objects in force mode,
hold a force, let go and open. Figures come from the recording (what the controller
saw) and from the simulator's truth (true angle and contact force)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from hand_service.app.daemon import Daemon, print_summary
from hand_service.config.profile import Profile
from hand_service.recording import read_recording
from hand_service.service.states import State
from hand_service.service.trajectory import CosineSweep, References, SmoothStep, Trajectory
from hand_service.simulator import Contact

SWEEP = CosineSweep()
PINCH_FINGERS = ("thumb", "index")
OBJECT_ANGLE_DEG = 100.0  # beyond the sweep's 90 deg, so only the pinch touches it
APPROACH_DEG = 90.0
FORCE_N = 1.5


@dataclass(frozen=True)
class Phases:
    settle_s: float = 0.5
    sweep_periods: int = 8
    rest_s: float = 0.5
    approach_s: float = 1.5
    force_ramp_s: float = 1.0
    force_hold_s: float = 2.5
    release_s: float = 0.5
    open_s: float = 1.5

    @property
    def sweep(self) -> tuple[float, float]:
        return self.settle_s, self.settle_s + self.sweep_periods * SWEEP.period_s

    @property
    def approach(self) -> tuple[float, float]:
        start = self.sweep[1] + self.rest_s
        return start, start + self.approach_s

    @property
    def force_hold(self) -> tuple[float, float]:
        start = self.approach[1] + self.force_ramp_s
        return start, start + self.force_hold_s

    @property
    def open(self) -> tuple[float, float]:
        start = self.force_hold[1] + self.release_s
        return start, start + self.open_s


def contacts(profile: Profile) -> dict[str, Contact]:
    return {name: Contact(OBJECT_ANGLE_DEG) for name in PINCH_FINGERS if name in profile.finger_names}


def demo_trajectory(profile: Profile, rate_hz: float, phases: Phases = Phases()) -> Trajectory:
    n = round(phases.open[1] * rate_hz) + 1
    traj = Trajectory.empty(n, len(profile.fingers), rate_hz, "demo: sweep, then pinch")
    t = np.arange(n) / rate_hz

    def rows(span: tuple[float, float]) -> slice:
        return slice(round(span[0] * rate_hz), round(span[1] * rate_hz))

    rest = References(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n))
    sweep = rows(phases.sweep)
    for i, name in enumerate(profile.finger_names):
        traj.set_position(slice(0, n), i, rest)
        traj.set_position(sweep, i, SWEEP.at(t[sweep] - phases.sweep[0]))
        if name not in PINCH_FINGERS:
            continue
        approach = rows(phases.approach)
        traj.set_position(approach, i, SmoothStep(0.0, APPROACH_DEG, phases.approach_s).at(
            t[approach] - phases.approach[0]))
        # force mode: up over force_ramp_s, hold, down over release_s (a trapezoid)
        force = rows((phases.approach[1], phases.open[0]))
        tf = t[force] - phases.approach[1]
        total = phases.open[0] - phases.approach[1]
        traj.set_force(force, i, FORCE_N * np.clip(np.minimum(tf / phases.force_ramp_s,
                                                              (total - tf) / phases.release_s), 0.0, 1.0))
        opening = rows(phases.open)
        traj.set_position(opening, i, SmoothStep(OBJECT_ANGLE_DEG, 0.0, phases.open_s).at(
            t[opening] - phases.open[0]))
    return traj


@dataclass
class DemoFigures:
    fingers: list[str]
    rmse_deg: np.ndarray
    max_error_deg: np.ndarray
    true_rmse_deg: np.ndarray
    force_fingers: list[str]
    force_est_rmse_n: np.ndarray
    force_true_rmse_n: np.ndarray
    force_true_mean_n: np.ndarray


def figures(path: str, profile: Profile, truth_angle_deg: np.ndarray, truth_force_n: np.ndarray,
            start_tick: int, phases: Phases = Phases()) -> DemoFigures:
    """Tracking over the sweep (its first period left out) and force over the hold."""
    names = profile.finger_names
    rmse, worst, true_rmse = [], [], []
    force_est, force_true, force_mean = [], [], []
    pinch = [n for n in names if n in PINCH_FINGERS]
    rate = profile.control.rate_hz
    for i, name in enumerate(names):
        rec = read_recording(path, finger=name)
        traj_t = rec.t_s - start_tick / rate
        lo, hi = phases.sweep[0] + SWEEP.period_s, phases.sweep[1]
        window = (traj_t >= lo) & (traj_t < hi)
        err = (rec.angle_deg - rec.columns["angle_ref_deg"])[window]
        rmse.append(np.sqrt(np.mean(err**2)))
        worst.append(np.max(np.abs(err)))
        ticks = np.round(rec.t_s * rate).astype(int)
        true_err = truth_angle_deg[ticks[window], i] - rec.columns["angle_ref_deg"][window]
        true_rmse.append(np.sqrt(np.mean(true_err**2)))
        if name in pinch:
            hold = (traj_t >= phases.force_hold[0]) & (traj_t < phases.force_hold[1])
            ref = rec.columns["force_ref_n"][hold]
            force_est.append(np.sqrt(np.mean((rec.columns["force_est_n"][hold] - ref) ** 2)))
            true = truth_force_n[ticks[hold], i]
            force_true.append(np.sqrt(np.mean((true - ref) ** 2)))
            force_mean.append(np.mean(true))
    return DemoFigures(names, np.array(rmse), np.array(worst), np.array(true_rmse), pinch,
                       np.array(force_est), np.array(force_true), np.array(force_mean))


def run_demo(daemon: Daemon, record: Path | None, out: TextIO) -> int:
    """Arm, run the demo trajectory through the daemon, stop when it ends, print figures."""
    sup, profile = daemon.sup, daemon.profile
    if record is None:
        record = Path("out") / time.strftime("demo-%Y%m%d-%H%M%S.csv")
    daemon.options.record = record
    phases = Phases()
    traj = demo_trajectory(profile, sup.rate_hz, phases)
    simulator = daemon.transport.simulator  # type: ignore[attr-defined]  # the demo is sim-only
    limit_s = traj.duration_s + 5.0
    n = round(limit_s * sup.rate_hz) + 2
    truth_angle = np.full((n, len(profile.fingers)), np.nan)
    truth_force = np.full((n, len(profile.fingers)), np.nan)
    started: list[int] = []

    def drive(_slack_ns: int) -> None:
        # the simulator now holds the state the next tick reads; after a skipped deadline
        # that tick's index is more than one ahead, so ask the schedule, not tick_index + 1
        k = sup.next_tick_index
        if k < n:
            truth_angle[k] = simulator.outputs.angle_deg
            truth_force[k] = simulator.outputs.contact_force_n
        if sup.state is State.DISARMED and not started:
            sup.set_trajectory(traj)
            sup.arm()
            sup.start()
            started.append(sup.tick_index + 1)
        elif started and (playing := sup.trajectory_status()) is not None and playing.done:
            sup.request_stop("demo finished")

    sup.add_slack(drive, first=True)
    out.write(f"demo on {profile.name}: {len(profile.fingers)} fingers at {sup.rate_hz:g} Hz. "
              f"0 -> 90 deg sweep ({phases.sweep_periods} periods of {SWEEP.period_s} s) on every finger,\n"
              f"then a pinch: {' and '.join(PINCH_FINGERS)} close on objects at {OBJECT_ANGLE_DEG:g} deg "
              f"and press {FORCE_N:g} N in force mode. About {traj.duration_s:.0f} s; "
              f"recording to {record}\n")
    out.flush()
    daemon.open()
    summary = daemon.run(limit_s)
    print_summary(summary, out)
    if not started or summary["stop_reason"] != "demo finished":
        out.write(f"the demo did not finish ({summary['stop_reason']}, state {summary['state']})\n")
        return 1
    fig = figures(str(record), profile, truth_angle, truth_force, started[0], phases)
    out.write(f"\nsweep tracking (first period left out)\n{'finger':<8} {'RMSE (deg)':>11} "
              f"{'max err (deg)':>14} {'RMSE true angle':>16}\n")
    for name, r, m, tr in zip(fig.fingers, fig.rmse_deg, fig.max_error_deg, fig.true_rmse_deg, strict=True):
        out.write(f"{name:<8} {r:11.2f} {m:14.2f} {tr:16.2f}\n")
    out.write(f"{'mean':<8} {fig.rmse_deg.mean():11.2f} {fig.max_error_deg.mean():14.2f} "
              f"{fig.true_rmse_deg.mean():16.2f}\n")
    noise = profile.simulation["sensor_noise_deg"]
    out.write(f"(RMSE and max error against the calibrated sensor angle, {noise:g} deg noise "
              "included; the last column against the simulator's true angle)\n")
    out.write(f"\npinch, force held at {FORCE_N:g} N\n{'finger':<8} {'RMSE est (N)':>13} "
              f"{'RMSE true (N)':>14} {'mean true (N)':>14}\n")
    for name, e, tr, mean in zip(fig.force_fingers, fig.force_est_rmse_n, fig.force_true_rmse_n,
                                 fig.force_true_mean_n, strict=True):
        out.write(f"{name:<8} {e:13.3f} {tr:14.3f} {mean:14.3f}\n")
    out.write(f"\nrecording: {record} ({summary['ticks']} ticks)\n")
    return 0
