"""The C simulator against analytic responses, and its valve, contact and sensor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtcore import Effects, Prbm
from rtcore.sim import SimFinger, Simulator, simulate

INDEX = SimFinger(Prbm(inertia_kgm2=1.6166e-4, damping_nms_per_rad=0.0031, stiffness_nm_per_rad=0.570,
                       pressure_gain_nm_per_kpa=8.9535e-3, lever_arm_m=0.040375))


def step_response_deg(f: SimFinger, pressure_kpa: float, t: np.ndarray) -> np.ndarray:
    """Underdamped second order: θ = θss·(1 − e^(−ζωt)(cos ωd t + ζ/√(1−ζ²) sin ωd t))."""
    m = f.prbm
    wn = math.sqrt(m.stiffness_nm_per_rad / m.inertia_kgm2)
    zeta = m.damping_nms_per_rad / (2 * math.sqrt(m.stiffness_nm_per_rad * m.inertia_kgm2))
    wd = wn * math.sqrt(1 - zeta**2)
    ss = m.pressure_gain_nm_per_kpa * pressure_kpa / m.stiffness_nm_per_rad
    return np.degrees(ss * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2)
                                                           * np.sin(wd * t))))


@pytest.mark.parametrize("rate_hz", [100.0, 500.0])
def test_pressure_step_matches_the_analytic_response(rate_hz: float) -> None:
    n = int(3 * rate_hz)
    angle, _ = simulate(INDEX, np.full(n, 60.0), rate_hz, substeps=int(1000 / rate_hz))
    exact = step_response_deg(INDEX, 60.0, np.arange(n) / rate_hz)
    assert np.max(np.abs(angle - exact)) < 1e-4


def test_free_decay_matches_the_analytic_response() -> None:
    angle, _ = simulate(INDEX, np.zeros(200), 100.0, angle0_deg=30.0)
    m = INDEX.prbm
    wn = math.sqrt(m.stiffness_nm_per_rad / m.inertia_kgm2)
    zeta = m.damping_nms_per_rad / (2 * math.sqrt(m.stiffness_nm_per_rad * m.inertia_kgm2))
    wd, t = wn * math.sqrt(1 - zeta**2), np.arange(200) / 100.0
    exact = 30.0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    assert np.max(np.abs(angle - exact)) < 1e-4


def test_valve_lag_is_first_order_and_dead_time_delays() -> None:
    lagged = INDEX.replace(effects=Effects(valve_lag_tau_s=0.05))
    _, chamber = simulate(lagged, np.full(100, 100.0), 100.0)
    t = np.arange(100) / 100.0
    np.testing.assert_allclose(chamber, 100.0 * (1 - np.exp(-t / 0.05)), atol=1e-9)
    delayed = INDEX.replace(effects=Effects(valve_lag_tau_s=0.05, dead_time_s=0.0237))
    _, chamber_d = simulate(delayed, np.full(100, 100.0), 100.0)
    expected = np.where(t > 0.0237, 100.0 * (1 - np.exp(-(t - 0.0237) / 0.05)), 0.0)
    np.testing.assert_allclose(chamber_d, expected, atol=1e-9)


def test_contact_gives_the_true_force_at_the_force_point() -> None:
    f = INDEX.replace(contact_angle_deg=40.0, contact_stiffness_n_per_m=2000.0, contact_damping_ns_per_m=5.0)
    sim = Simulator([f], substeps=20)
    sim.command_kpa[:] = 150.0
    for _ in range(300):
        sim.step()
    theta = math.radians(sim.outputs.angle_deg[0])
    # at rest: N p = k θ + r F
    m = f.prbm
    expected = (m.pressure_gain_nm_per_kpa * 150.0 - m.stiffness_nm_per_rad * theta) / m.lever_arm_m
    assert sim.outputs.contact_force_n[0] == pytest.approx(expected, rel=1e-6)
    assert sim.outputs.angle_deg[0] > 40.0


def test_sensor_noise_quantisation_and_seed() -> None:
    noisy = INDEX.replace(sensor_gain_deg_per_mv=0.1, sensor_offset_deg=-50.0, sensor_noise_deg=0.3,
                          adc_step_mv=1.22)
    readings = []
    for seed in (7, 7, 8):
        sim = Simulator([noisy], seed=seed)
        mv = []
        for _ in range(4000):
            sim.step()
            mv.append(sim.outputs.sensor_mv[0])
        readings.append(np.array(mv))
    np.testing.assert_array_equal(readings[0], readings[1])
    assert not np.array_equal(readings[0], readings[2])
    angle = 0.1 * readings[0] - 50.0
    assert np.std(angle) == pytest.approx(0.3, rel=0.1)
    steps = np.unique(np.round(np.diff(np.unique(readings[0])) / 1.22, 6))
    assert steps.min() == pytest.approx(1.0)


def test_sixty_seconds_of_five_fingers_is_fast(benchmark) -> None:
    """Measured as a benchmark (`make bench`), never asserted as a time."""
    fingers = [INDEX.replace(effects=Effects(valve_lag_tau_s=0.03, dead_time_s=0.005))] * 5

    def sixty_seconds() -> float:
        sim = Simulator(fingers)
        sim.command_kpa[:] = 80.0
        for _ in range(6000):
            sim.step()
        return float(sim.outputs.angle_deg[0])

    assert benchmark(sixty_seconds) > 0.0


@pytest.mark.parametrize("torque_nm", [0.002, 0.034])
def test_stiff_dry_friction_is_integrated_accurately(torque_nm: float) -> None:
    """Dry friction's tanh slope (Tc/ω_s) is stiff: the simulator takes shorter steps where
    it must, so 10 nominal sub-steps agree with 1000 (at 0.034 N·m on the thumb, plain 1 ms
    RK4 steps are unstable and invent a sticking the physics does not have)."""
    thumb = SimFinger(Prbm(9.068e-5, 0.0011, 0.6541, 8.2197e-3, 0.031875,
                           effects=Effects(coulomb_torque_nm=torque_nm, valve_lag_tau_s=0.03,
                                           dead_time_s=0.005)))
    t = np.arange(2000) / 100.0
    pressure = 60.0 + 40.0 * np.sign(np.sin(2 * np.pi * 0.5 * t))
    coarse, _ = simulate(thumb, pressure, 100.0, substeps=10)
    fine, _ = simulate(thumb, pressure, 100.0, substeps=1000)
    assert np.max(np.abs(coarse - fine)) < 0.05
