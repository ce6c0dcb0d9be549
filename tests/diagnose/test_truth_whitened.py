"""The single-case analysis beside the battery's judge (tests/diagnose/truth/whitened.py):
its innovations filter against the sensor's own noise, and its fit against signatures of
known size."""

from __future__ import annotations

import numpy as np
import pytest

from tests.diagnose.truth.linear import LinearModel, response_deg
from tests.diagnose.truth.sensor import Sensor
from tests.diagnose.truth.whitened import Whitener, leftover, main, sensor_whitener

RATE_HZ = 200.0
MODEL = LinearModel(1e-5, 0.05, 0.5, 0.01)


def test_the_filter_whitens_the_sensors_noise_to_its_stated_rms() -> None:
    """White, AR(1) and ADC-like parts together (a coarse ADC, its rounding a third of the
    white part's variance): the innovations are white (lags 1-5 under 0.01) and of the RMS
    the factorisation states (within 2 %); left without the rounding, the factorisation is
    3 % off; the AR pole alone would leave them correlated."""
    sensor = Sensor(white_deg=0.1, correlated_deg=0.25, correlation_s=0.1, adc_step_deg=0.25)
    rng = np.random.default_rng(4)
    n = 400_000
    noise = (sensor.correlated(rng, n, RATE_HZ) + rng.normal(0.0, sensor.white_deg, n)
             + rng.uniform(-0.5, 0.5, n) * sensor.adc_step_deg)
    whitener = sensor_whitener(sensor, RATE_HZ)
    e = whitener.apply(noise)[100:]
    e = e - e.mean()
    lags = [float(e[k:] @ e[:-k] / (e @ e)) for k in range(1, 6)]
    assert max(abs(r) for r in lags) < 0.01, lags
    assert np.std(e) == pytest.approx(whitener.std_deg, rel=0.02)
    no_adc = sensor_whitener(Sensor(white_deg=0.1, correlated_deg=0.25, correlation_s=0.1, adc_step_deg=0.0),
                             RATE_HZ)
    assert abs(np.std(no_adc.apply(noise)[100:]) / no_adc.std_deg - 1.0) > 0.03
    pole_only = Whitener(whitener.pole, 0.0, 1.0).apply(noise)[100:]
    assert abs(float(pole_only[1:] @ pole_only[:-1] / (pole_only @ pole_only))) > 0.1


def test_a_change_of_k_and_b_is_absorbed_and_a_swing_is_not() -> None:
    """The fit absorbs what is only another k and B (twice the damping and a fifth more
    stiffness: nothing left; on this over-damped finger the data fix B/k and N/k, the prior
    the rest) and leaves a swing the plain finger cannot make whole."""
    t = np.arange(6000) / RATE_HZ
    command = np.where((t % 4.0) < 2.0, 50.0, 10.0)
    white = Whitener(0.0, 0.0, 0.1)
    other = LinearModel(1e-5, 0.1, 0.6, 0.01)
    truth = response_deg(other, command, RATE_HZ)
    absorbed = leftover("valve_lag", truth, command, RATE_HZ, MODEL, 0.0, white)
    assert absorbed.rms < 0.02
    k, b, n = absorbed.factors
    assert b / k == pytest.approx(2.0 / 1.2, rel=0.02)
    assert n / k == pytest.approx(1.0 / 1.2, rel=0.02)
    swing = 0.1 * np.sin(2 * np.pi * 7.0 * t)
    kept = leftover("valve_lag", response_deg(MODEL, command, RATE_HZ) + swing, command, RATE_HZ, MODEL, 0.0,
                    white)
    assert kept.rms == pytest.approx(np.sqrt(np.mean(swing**2)) / 0.1, rel=0.1)


def test_a_bad_case_id_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["not-a-case"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a battery case id" in err
