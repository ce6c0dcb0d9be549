"""The sensor's offset drift the noise model takes, said under a verdict that calls the
residual noise (hand_service/diagnose/residual/offset_drift.py)."""

from __future__ import annotations

import numpy as np

from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose

NOISE_DEG = 0.2
DRIFT_DEG = 0.6  # a drift's amplitude over 17 s (an outside probe's sensor drifted by 1.5°)
SAID = "the noise model takes a slow drift of the sensor's offset"


def _diagnosed(drift_deg: float):
    c = generate(load_profile(None).finger("index").model, {}, "steps", noise_deg=NOISE_DEG, seed=31,
                 perturbation=0.1)
    angle = c.angle_deg + drift_deg * np.sin(2.0 * np.pi * c.t_s / 17.0 + 0.7)
    return diagnose(c.nominal, c.t_s, c.pressure_kpa, angle, 1.0 / (c.t_s[1] - c.t_s[0]))


def test_a_drift_the_noise_model_takes_is_said_with_its_size_on_the_raw_angle() -> None:
    d = _diagnosed(DRIFT_DEG)
    assert d.verdict in ("consistent", "parameters_only"), d.warnings
    said = [w for w in d.warnings if w.startswith(SAID)]
    assert len(said) == 1, d.warnings
    drift_deg = float(said[0].split(SAID + ", ")[1].split(" deg RMS")[0])
    true_deg = DRIFT_DEG / np.sqrt(2.0)  # a sine's RMS, the recording spanning about two periods
    assert abs(drift_deg - true_deg) < 0.15 * true_deg, (drift_deg, true_deg)
    assert f"misses the raw angle by {d.raw.raw_deg['refit']:.3g} deg RMS" in said[0]


def test_a_sensor_that_holds_its_offset_gets_no_drift_sentence() -> None:
    d = _diagnosed(0.0)
    assert d.verdict in ("consistent", "parameters_only"), d.warnings
    assert not [w for w in d.warnings if w.startswith(SAID)]


def test_a_drift_a_raw_refit_nests_is_not_named_creep() -> None:
    """A faster sweep's drift: creep, fitted on the innovations, does not follow the raw angle;
    refitted there it lowers the raw error by 0.1 %, within the recording's fluctuation, so it
    is not named."""
    c = generate(load_profile(None).finger("index").model, {}, "sweep", noise_deg=NOISE_DEG, seed=31,
                 perturbation=0.1)
    angle = c.angle_deg + 1.5 * np.sin(2.0 * np.pi * c.t_s / 17.0 + 0.7)
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, angle, 1.0 / (c.t_s[1] - c.t_s[0]))
    assert d.effects == [], (d.verdict, [e.name for e in d.effects])
    assert any("beyond the recording's fluctuation" in w for w in d.warnings), d.warnings
