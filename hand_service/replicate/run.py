"""`replicate`: the paper's Tables 1 and 2 and its force test, entirely in simulation.

The truth is a profile's hand (default sim.yaml: the paper's Table 1 with a 30 ms valve
lag and 5 ms dead time, 0.3° sensor noise). The controller knows only what the lab
measured on simulated recordings with the project's own calibrate and identify
(hand_service.measured_hand). Then, in closed loop with the C control step:

- Table 1: k and B per finger by identify (and by the paper's two-peak recipe);
- Table 2: the cosine sweep 45·(1 − cos(2πt/0.75 s)) for 10 periods, the first left out,
  by PRBM+LDM feedforward + PID (the profile's gains, untuned) and by PID alone (tuned
  to its best, hand_service.tracking);
- force: the finger at 90° against an object, the pressure ramped until the true force
  reaches 2 N; the controller's estimate against the true force.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.effects import effect_value
from hand_service.force_test import CONTACT_ANGLE_DEG, ForceRun, run_force_test
from hand_service.measured_hand import MeasuredFinger, controller_profile, measure_finger
from hand_service.profile import Profile, load_profile
from hand_service.simulator import Contact, Simulator, hand_simulator
from hand_service.tracking import TUNED, TrackingRun, Tuning, pid_alone, track, tune_pid, with_gains
from hand_service.version import software_version

# The paper's Table 1 (k in N·m/rad, B in N·m·s/rad; averages of 10 trials) and Table 2
# (RMSE and max error in deg), as printed (physics.md §2 and §5).
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
        from hand_service.replicate_tables import markdown

        return markdown(self)


def _make_sim(truth: Profile, contacts: dict[str, Contact] | None = None) -> Callable[[int], Simulator]:
    return lambda seed: hand_simulator(truth, seed=seed, contacts=contacts)


def check_truth(truth: Profile) -> None:
    from hand_service.errors import UserError

    if truth.simulation["sensor_noise_deg"] < 0.3:
        raise UserError(f"{truth.path}: replicate needs sensor noise >= 0.3 deg "
                        f"(simulation.sensor_noise_deg is {truth.simulation['sensor_noise_deg']:g})")
    for f in truth.fingers:
        lag = effect_value(f.model.effects, "valve_lag")
        if lag < 0.03:
            raise UserError(f"{truth.path}: replicate needs a valve lag >= 30 ms in every finger "
                            f"(hand.{f.name}.effects.valve_lag.tau_s is {lag:g} s)")


def replicate(options: Options, progress: Callable[[str], None] | None = None) -> Result:
    say = progress or (lambda _: None)
    started = time.perf_counter()
    truth = load_profile(options.profile)
    check_truth(truth)
    seeds = [int(s) for s in np.random.SeedSequence([options.seed]).generate_state(len(truth.fingers) + 3)]
    with tempfile.TemporaryDirectory(prefix="replicate-") as scratch:
        workdir = options.trials_dir or Path(scratch)
        workdir.mkdir(parents=True, exist_ok=True)
        say(f"measuring the simulated hand ({options.trials_per_finger} releases a finger) into {workdir}")
        measured = [measure_finger(f, truth.simulation, workdir, options.trials_per_finger, seeds[i], say)
                    for i, f in enumerate(truth.fingers)]
    controller = controller_profile(truth, measured)
    config = controller.hand_config()
    make_sim = _make_sim(truth)
    evaluation_seed, force_seed, tuning_seed = seeds[-3:]  # tuning also uses tuning_seed + 1
    say(f"Table 2: FF+PID tracking the sweep for {options.periods} periods")
    ff_pid = track(config, make_sim, evaluation_seed, options.periods)
    say("Table 2: tuning PID alone to its best (grid, then compass searches)")
    tuning = tune_pid(config, make_sim, tuning_seed, options.periods, options.quick, say)
    pid = track(with_gains(pid_alone(config), tuning.gains), make_sim, evaluation_seed, options.periods)
    say(f"force test: object at {CONTACT_ANGLE_DEG:g} deg, pressure ramped to 2 N true force")
    contacts = {f.name: Contact(CONTACT_ANGLE_DEG) for f in truth.fingers}
    force = run_force_test(controller, _make_sim(truth, contacts), force_seed)
    runs = [dataclasses.replace(run, fingers=truth.finger_names) for run in (ff_pid, pid)]
    force = dataclasses.replace(force, fingers=truth.finger_names)
    return Result(options, truth, controller, measured, runs[0], runs[1], tuning, force,
                  time.perf_counter() - started)


__all__ = ["PAPER_FORCE", "PAPER_LDM", "PAPER_POSITION", "TUNED", "Options", "Result", "replicate"]
