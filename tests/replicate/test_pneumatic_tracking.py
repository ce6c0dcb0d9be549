"""FF+PID tracking of the paper's cosine, 45·(1 − cos(2πt/0.75 s)) for 10 periods, the first left
out (replicate's Table 2 run, hand_service.replicate.tracking.track), on the first-order valve and
on the pneumatic plant, with the same controller (sim.yaml's: valve lag 30 ms, dead time 5 ms)
and the same noise seed. Prints both figures; docs/physics.md reports them."""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import Profile, load_profile
from hand_service.identification import trials
from hand_service.identification.calibration import fit_valve
from hand_service.recording import read_recording
from hand_service.replicate.tracking import TrackingRun, track
from hand_service.simulator import hand_simulator
from tests.rtcore.test_pneumatic_valve import write_pneumatic_profile

PAPER_FF_PID_RMSE_DEG = 2.37  # the paper's Table 2
SEED = 7


def tracking(truth: Profile, config_profile: Profile) -> TrackingRun:
    return track(config_profile.hand_config(), lambda seed: hand_simulator(truth, seed=seed), SEED)


def with_pneumatics(profile: Profile, **changes: float) -> Profile:
    simulation = copy.deepcopy(profile.simulation)
    simulation["pneumatics"].update(changes)
    return dataclasses.replace(profile, simulation=simulation)


def calibrated(truth: Profile, controller: Profile, directory: Path) -> Profile:
    """`controller` with each finger's valve_lag and dead_time from calibrate valve's fit to a
    0 -> 60 kPa step recorded from `truth`."""
    fingers = []
    for i, finger in enumerate(controller.fingers):
        step = trials.valve_steps(truth.fingers[i], truth.simulation, seed=40 + i,
                                  levels_kpa=(0.0, 60.0, 60.0))
        fit = fit_valve(read_recording(step.write(directory / f"{finger.name}_step.csv")))
        fingers.append(dataclasses.replace(finger, model=finger.model.with_changes(
            effects={**finger.model.effects, **fit.effects()})))
    return dataclasses.replace(controller, fingers=fingers)


def test_ff_pid_tracking_on_the_pneumatic_plant_beside_the_first_order_valve(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    first_order = load_profile()
    pneumatic = load_profile(write_pneumatic_profile(tmp_path))
    bigger_exhaust = with_pneumatics(pneumatic, exhaust_conductance_dm3_per_s_bar=0.15)
    runs = {"first-order valve (30 ms lag, 5 ms dead time)": tracking(first_order, first_order),
            "pneumatic plant, the board's valves (exhaust C 0.07)": tracking(pneumatic, first_order),
            "pneumatic plant, valve lag from calibrate valve on a step": tracking(
                pneumatic, calibrated(pneumatic, first_order, tmp_path)),
            "pneumatic plant, exhaust C 0.15 dm³/(s·bar)": tracking(bigger_exhaust, first_order)}
    with capsys.disabled():
        print("\n| plant | FF+PID RMSE (deg) | max error (deg) |")
        for name, run in runs.items():
            print(f"| {name} | {run.rmse_deg.mean():.2f} | {run.max_error_deg.mean():.2f} |")
    first, board, board_calibrated, bigger = (float(run.rmse_deg.mean()) for run in runs.values())
    assert all(np.isfinite(run.angle_deg).all() for run in runs.values())
    assert first < 1.6  # replicate's 1.34° comes from the measured controller; the truth's is as good
    # the board's exhaust cannot empty the chamber (up to ~27 mL at 110°) within the cosine's
    # fall: the vent is flow-limited and the finger lags on every way down
    assert board > 3 * first
    board_run = runs["pneumatic plant, the board's valves (exhaust C 0.07)"]
    down = np.gradient(board_run.reference_deg) < 0
    error = board_run.angle_deg - board_run.reference_deg[:, None]
    assert float(np.mean(error[down])) > 3.0  # above the reference on the way down
    assert board_calibrated > 3 * first  # no feedforward lead opens the exhaust wider
    # a larger exhaust valve lifts that limit: within the paper's figure
    assert bigger < PAPER_FF_PID_RMSE_DEG
