"""`calibrate valve` on the pneumatic plant (simulation.valve_model: pneumatic): the lag and dead
time it identifies from a recorded pressure step against an independent fit made here, and the
rising and falling steps fitted alone."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import curve_fit

from hand_service.cli import main
from hand_service.config.profile import PROFILE_DIR, Profile, load_profile
from hand_service.identification import trials
from hand_service.identification.calibration import fit_valve
from hand_service.recording import read_recording
from tests.rtcore.test_pneumatic_valve import write_pneumatic_profile

STEP_KPA = 60.0


@pytest.fixture(scope="module")
def pneumatic_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_pneumatic_profile(tmp_path_factory.mktemp("pneumatic"))


@pytest.fixture(scope="module")
def pneumatic(pneumatic_path: Path) -> Profile:
    return load_profile(pneumatic_path)


def fopdt_kpa(t_s: np.ndarray, tau_s: float, delay_s: float, gain_kpa: float) -> np.ndarray:
    """A first-order lag behind a dead time, stepped at t = 0, in closed form."""
    after = np.clip(t_s - delay_s, 0.0, None)
    return np.where(t_s > delay_s, gain_kpa * (1.0 - np.exp(-after / tau_s)), 0.0)


def independent_fit(command_kpa: np.ndarray, measured_kpa: np.ndarray, rate_hz: float) -> tuple[float, float]:
    """τ and the dead time by scipy's curve_fit of the closed-form step response (its final
    value free) to the measured samples: sample k is read at k/rate, the command changes at
    the step's sample."""
    step = int(np.flatnonzero(np.diff(command_kpa))[0]) + 1
    t_s = (np.arange(command_kpa.size) - step) / rate_hz
    (tau_s, delay_s, _), _ = curve_fit(fopdt_kpa, t_s, measured_kpa, p0=(0.03, 0.005, STEP_KPA),
                                       bounds=([1e-4, 0.0, 0.0], [1.0, 0.2, 10 * STEP_KPA]))
    return float(tau_s), float(delay_s)


def test_calibrate_valve_on_a_pneumatic_step_agrees_with_an_independent_fit(
        pneumatic: Profile, pneumatic_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One 0 -> 60 kPa step per finger, recorded from the pneumatic plant with the measured
    chamber pressure (0.5 kPa noise): calibrate valve's τ and τ + dead time (the lead the
    feedforward applies) within 15 % of curve_fit's, its dead time within 15 % of that sum."""
    rows = []
    for i, finger in enumerate(pneumatic.fingers):
        recording = trials.valve_steps(finger, pneumatic.simulation, seed=40 + i,
                                       levels_kpa=(0.0, STEP_KPA, STEP_KPA))
        path = recording.write(tmp_path / f"{finger.name}_step.csv")
        out = tmp_path / f"{finger.name}.json"
        assert main(["calibrate", "valve", str(path), "--model", str(pneumatic_path), "--finger", finger.name,
                     "--json", str(out)]) == 0
        ours = json.loads(out.read_text())
        data = read_recording(path)
        tau_s, delay_s = independent_fit(data.pressure_kpa, data.optional("pressure_meas_kpa"),
                                         data.sample_rate_hz)
        rows.append((finger.name, ours["valve_lag_tau_s"], ours["dead_time_s"], tau_s, delay_s))
    capsys.readouterr()
    with capsys.disabled():
        print("\n| finger | calibrate valve tau / dead time (ms) | curve_fit tau / dead time (ms) | tau "
              "| tau + dead time |")
        for name, tau, delay, ind_tau, ind_delay in rows:
            lead = (tau + delay) / (ind_tau + ind_delay) - 1
            print(f"| {name} | {1e3 * tau:.1f} / {1e3 * delay:.1f} "
                  f"| {1e3 * ind_tau:.1f} / {1e3 * ind_delay:.1f} "
                  f"| {100 * (tau / ind_tau - 1):+.1f} % | {100 * lead:+.1f} % |")
    for name, tau, delay, ind_tau, ind_delay in rows:
        assert tau == pytest.approx(ind_tau, rel=0.15), name
        assert tau + delay == pytest.approx(ind_tau + ind_delay, rel=0.15), name
        assert abs(delay - ind_delay) <= 0.15 * (ind_tau + ind_delay), name
    # the lag is emergent: the middle finger, whose chamber grows most per radian (largest N),
    # fills slowest, and none is the 30 ms the profile's first-order valve assumes
    by_name = {row[0]: row[1] for row in rows}
    assert by_name["middle"] > 1.3 * by_name["thumb"]
    assert all(abs(tau / 0.03 - 1) > 0.1 for tau in by_name.values())


def test_the_pneumatic_plant_vents_slower_than_it_fills(pneumatic: Profile, tmp_path: Path) -> None:
    """calibrate valve's rising and falling fits: on the pneumatic plant the vent (subsonic
    flow out through the exhaust, against the air the finger's spring pushes back) is the slow
    direction; on the first-order plant both directions give its 30 ms."""
    first_order = load_profile()
    finger = "index"
    pneumatic_path = trials.valve_steps(pneumatic.finger(finger), pneumatic.simulation, seed=5).write(
        tmp_path / "pneumatic.csv")
    first_path = trials.valve_steps(first_order.finger(finger), first_order.simulation, seed=5).write(
        tmp_path / "first.csv")
    rising, falling = (fit_valve(read_recording(pneumatic_path), steps) for steps in ("rising", "falling"))
    assert falling.tau_s > 2.0 * rising.tau_s
    first_hold = round(0.5 * 100)  # before the first step: judged in neither direction
    assert rising.samples + falling.samples == rising.command_kpa.size - first_hold
    for steps in ("rising", "falling"):
        fit = fit_valve(read_recording(first_path), steps)
        assert fit.tau_s == pytest.approx(0.03, rel=0.1)
        assert fit.delay_s == pytest.approx(0.005, abs=0.0015)


def test_calibrate_valve_prints_and_writes_each_direction(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    profile = load_profile()
    path = trials.valve_steps(profile.finger("thumb"), profile.simulation, seed=9).write(tmp_path / "v.csv")
    out = tmp_path / "v.json"
    model = str(PROFILE_DIR / "sim.yaml")
    assert main(["calibrate", "valve", str(path), "--model", model, "--finger", "thumb",
                 "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| all |" in printed and "| rising |" in printed and "| falling |" in printed
    data = json.loads(out.read_text())
    keys = {"valve_lag_tau_s", "dead_time_s", "rmse_kpa", "samples"}
    assert set(data["rising"]) == set(data["falling"]) == keys
    up = trials.valve_steps(profile.finger("thumb"), profile.simulation, seed=9, levels_kpa=(0.0, 50.0, 50.0))
    up_path = up.write(tmp_path / "up.csv")
    assert main(["calibrate", "valve", str(up_path), "--model", model, "--finger", "thumb",
                 "--json", str(out)]) == 0
    assert "falling" not in json.loads(out.read_text())  # no falling step: no row for it
