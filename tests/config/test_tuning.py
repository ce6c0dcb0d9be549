"""Default PI gains by gain margin: the predicted critical gain is the simulator's, and
the defaults hold every finger of every shipped profile still."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import rtcore
from hand_service.config.profile import PROFILE_DIR, Profile, load_profile
from hand_service.config.tuning import GAIN_MARGIN, margin_gains, sos_response, valve_lag_s
from hand_service.simulator import profile_sim_finger
from rtcore.sim import Simulator

QUIET = {"sensor_noise_deg": 0.0, "adc_step_mv": 0.0, "pressure_noise_kpa": 0.0}


def hold(profile: Profile, i: int, kp: float, ki: float, noise: bool, seconds: float = 8.0) -> np.ndarray:
    """Closed loop on one finger holding 45 deg; returns the true angle, sample by sample."""
    config = profile.hand_config()
    finger = config.fingers[i].replace(kp_kpa_per_deg=kp, ki_kpa_per_deg_s=ki)
    hand = rtcore.Hand(rtcore.HandConfig([finger], config.sample_rate_hz))
    simulation = profile.simulation if noise else {**profile.simulation, **QUIET}
    sim = Simulator([profile_sim_finger(profile.fingers[i], simulation)], config.sample_rate_hz)
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    hand.inputs.angle_ref_deg[:] = 45.0
    angle = np.empty(round(seconds * config.sample_rate_hz))
    for k in range(angle.size):
        hand.inputs.sensor_mv[:] = sim.outputs.sensor_mv
        hand.step()
        sim.command_kpa[:] = hand.outputs.pressure_cmd_kpa
        sim.step()
        angle[k] = sim.outputs.angle_deg[0]
    return angle


@pytest.mark.parametrize("finger", ["middle", "thumb"])
def test_critical_gain_is_where_the_loop_starts_to_oscillate(finger: str) -> None:
    profile = load_profile()
    i = profile.finger_names.index(finger)
    gains = margin_gains(profile.fingers[i].rtcore_config(profile.control), profile.control.rate_hz)
    # below the critical gain the loop settles; above it, it oscillates until the pressure
    # limits hold the swing (a limit cycle), so judge the last quarter's spread
    for factor, oscillates in ((0.8, False), (1.3, True)):
        angle = hold(profile, i, factor * gains.critical_kp_kpa_per_deg, 0.0, noise=False)
        spread = np.std(angle[3 * angle.size // 4:])
        assert (spread > 1.0) == oscillates, f"{factor} x critical: std {spread:.3g} deg at the end"


@pytest.mark.parametrize(("finger", "vent_over_fill"), [("middle", 4.0), ("thumb", 2.0)])
def test_a_slower_vent_moves_the_critical_gain_as_predicted(finger: str, vent_over_fill: float) -> None:
    """With a vent lag of its own (valve_vent_lag), the loop's τ is the geometric mean of the
    fill's and the vent's: below 0.8 times the predicted critical gain the loop settles, above
    1.3 times it oscillates (with the fill's lag alone the prediction is half the gain)."""
    profile = load_profile()
    i = profile.finger_names.index(finger)
    fill_s = 0.04
    effects = {**profile.fingers[i].model.effects, "valve_lag": {"tau_s": fill_s},
               "valve_vent_lag": {"tau_s": vent_over_fill * fill_s}}
    fingers = list(profile.fingers)
    fingers[i] = dataclasses.replace(fingers[i], model=fingers[i].model.with_changes(effects=effects))
    profile = dataclasses.replace(profile, fingers=fingers)
    config = profile.fingers[i].rtcore_config(profile.control)
    assert valve_lag_s(config.prbm.effects) == pytest.approx(fill_s * math.sqrt(vent_over_fill))
    gains = margin_gains(config, profile.control.rate_hz)
    for factor, oscillates in ((0.8, False), (1.3, True)):
        angle = hold(profile, i, factor * gains.critical_kp_kpa_per_deg, 0.0, noise=False)
        spread = np.std(angle[3 * angle.size // 4:])
        assert (spread > 1.0) == oscillates, f"{factor} x critical: std {spread:.3g} deg at the end"


@pytest.mark.parametrize("path", sorted(PROFILE_DIR.glob("*.yaml")), ids=lambda p: p.name)
def test_default_gains_hold_every_finger_still(path) -> None:
    profile = load_profile(path)
    for i, finger in enumerate(profile.fingers):
        angle = hold(profile, i, finger.kp_kpa_per_deg, finger.ki_kpa_per_deg_s, noise=True)
        settled = angle[angle.size // 2:]
        worst = np.abs(settled - 45.0).max()
        assert worst < 1.0, f"{finger.name}: wanders {worst:.2f} deg"
        assert np.std(settled) < 0.2, f"{finger.name}: oscillates, std {np.std(settled):.2f} deg"


def test_gains_given_in_a_profile_win(tmp_path) -> None:
    text = (PROFILE_DIR / "sim.yaml").read_text().replace(
        "    pressure_max_kpa: 150\n", "    pressure_max_kpa: 150\n    kp_kpa_per_deg: 0.05\n", 1)
    path = tmp_path / "sim.yaml"
    path.write_text(text)
    middle = load_profile(path).finger("middle")
    assert middle.kp_kpa_per_deg == 0.05 and middle.ki_kpa_per_deg_s == pytest.approx(0.5)
    assert load_profile().finger("middle").kp_kpa_per_deg == pytest.approx(
        load_profile().finger("middle").ki_kpa_per_deg_s / 10)
    assert GAIN_MARGIN >= 2.0


@pytest.mark.parametrize(("order", "cutoff_hz", "rate_hz"),
                         [(2, 8.0, 100.0), (4, 30.0, 500.0), (4, 1.0, 25.0)])
def test_the_filters_response_is_scipys(order: int, cutoff_hz: float, rate_hz: float) -> None:
    """sos_response (numpy, so that reading a profile does not import scipy.signal) is sosfreqz."""
    from scipy import signal

    sos = rtcore.butter_design(order, cutoff_hz, rate_hz)
    freqs_hz = np.linspace(0.01, 0.499 * rate_hz, 400)
    _, expected = signal.sosfreqz(sos, worN=freqs_hz, fs=rate_hz)
    actual = sos_response(sos, np.exp(2j * np.pi * freqs_hz / rate_hz))
    np.testing.assert_allclose(actual, expected, rtol=1e-12, atol=1e-14)


def test_reading_a_profile_imports_no_scipy_signal() -> None:
    """Every process that reads a profile (the mock firmware, the hold host, the daemon)
    would pay scipy.signal's import, about 1 s: the mock took 1.4 s to start, 0.5 s without."""
    import subprocess
    import sys

    code = ("import sys; from hand_service.config.profile import load_profile; "
            "import hand_service.firmware.board; load_profile(None).hand_config(); "
            "print(sorted(m for m in sys.modules if m.startswith(('scipy.signal', 'scipy.stats'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out
