"""The simulator's pneumatic valve mode (csrc/rtcore_pneumatic.c): the board's chamber physics and
regulator against an independent integration of the same equations, the regulator's behaviour,
bad configs, the profile keys, and that the first-order valve is untouched."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hand_service.config.profile import PROFILE_DIR, load_profile
from hand_service.errors import UserError
from hand_service.simulator import hand_simulator
from rtcore import ConfigError, Effects, Prbm
from rtcore.pneumatic import VALVE_FIRST_ORDER, VALVE_PNEUMATIC, PneumaticValves, pneumatic_valves
from rtcore.sim import SimFinger, Simulator, simulate

ROOT = Path(__file__).resolve().parents[2]
PNEUMATIC_PROFILE = """\
profile: sim-pneumatic
protocol_version: 1
include: {sim}
transport:
  kind: sim
simulation:
  valve_model: pneumatic
"""
INDEX_PRBM = Prbm(inertia_kgm2=1.6166e-4, damping_nms_per_rad=0.0031, stiffness_nm_per_rad=0.570,
                  pressure_gain_nm_per_kpa=8.9535e-3, lever_arm_m=0.040375)
RATE_HZ = 1000.0  # one sample per regulator period: the chamber seen at every regulator tick



def write_pneumatic_profile(directory: Path) -> Path:
    """sim.yaml's hand and settings with every valve the board's pneumatics (docs/physics.md)."""
    path = directory / "sim-pneumatic.yaml"
    path.write_text(PNEUMATIC_PROFILE.format(sim=PROFILE_DIR / "sim.yaml"))
    return path


# ISO 8778's reference atmosphere and air's gas constant, as ISO 6358 states them
RHO0_KG_PER_M3 = 1.185
T0_K = 293.15
R_J_PER_KG_K = 287.05


def iso6358_kg_per_s(conductance_dm3_per_s_bar: float, b: float, up_pa: float, down_pa: float,
                     t_k: float) -> float:
    """ISO 6358 mass flow from up to down (absolute pressures), written here from the standard."""
    c = conductance_dm3_per_s_bar * 1e-3 / 1e5
    ratio = down_pa / up_pa
    phi = 1.0 if ratio <= b else math.sqrt(max(0.0, 1.0 - ((ratio - b) / (1.0 - b)) ** 2))
    return c * up_pa * RHO0_KG_PER_M3 * math.sqrt(T0_K / t_k) * phi


def independent_kpa(v: PneumaticValves, prbm: Prbm, t_s: np.ndarray, p0_kpa: float,
                    inlet: bool) -> np.ndarray:
    """The chamber with one valve held fully open from its opening delay on, coupled to the
    finger's PRBM, by scipy's LSODA: dp/dt = nRT/V·q − n·p/V·dV/dt, V = V0 + N·max(θ, 0)."""
    atm_pa = v.atmosphere_kpa * 1e3
    supply_pa = atm_pa + v.supply_kpa * 1e3
    opens_s = v.inlet_open_delay_s if inlet else v.exhaust_open_delay_s
    n = v.polytropic_index
    volume_per_rad_m3 = prbm.pressure_gain_nm_per_kpa * 1e-3

    def rhs(t: float, y: np.ndarray) -> list[float]:
        p_pa, theta, omega = y
        volume = v.dead_volume_ml * 1e-6 + volume_per_rad_m3 * max(theta, 0.0)
        dv_dt = volume_per_rad_m3 * omega if theta > 0.0 else 0.0
        flow = 0.0
        if t >= opens_s:
            if inlet:
                flow = iso6358_kg_per_s(v.inlet_conductance_dm3_per_s_bar, v.inlet_critical_ratio, supply_pa,
                                        p_pa, v.temperature_k)
            else:
                flow = -iso6358_kg_per_s(v.exhaust_conductance_dm3_per_s_bar, v.exhaust_critical_ratio, p_pa,
                                         atm_pa, v.temperature_k)
        dp = n * R_J_PER_KG_K * v.temperature_k / volume * flow - n * p_pa / volume * dv_dt
        torque = prbm.pressure_gain_nm_per_kpa * (p_pa - atm_pa) / 1e3
        accel = (torque - prbm.damping_nms_per_rad * omega
                 - prbm.stiffness_nm_per_rad * theta) / prbm.inertia_kgm2
        return [dp, omega, accel]

    y0 = [atm_pa + p0_kpa * 1e3, 0.0, 0.0]
    if p0_kpa > 0.0:  # a finger at rest under its chamber's pressure
        y0[1] = prbm.pressure_gain_nm_per_kpa * p0_kpa / prbm.stiffness_nm_per_rad
    sol = solve_ivp(rhs, (0.0, float(t_s[-1])), y0, method="LSODA", t_eval=t_s, rtol=1e-9,
                    atol=[1e-3, 1e-9, 1e-9], max_step=1e-4)
    return (sol.y[0] - atm_pa) / 1e3


@pytest.mark.parametrize("inlet", [True, False], ids=["filling", "venting"])
def test_chamber_and_finger_match_an_independent_integration(inlet: bool) -> None:
    """Filling from 0 towards a 300 kPa command (the regulator at full inlet duty while the
    error exceeds 1000/60 kPa), and venting from 200 kPa on a 0 command, with the index
    finger bending the chamber's volume: the simulator's chamber against LSODA on the same
    equations written independently here."""
    valves = pneumatic_valves()
    finger = SimFinger(INDEX_PRBM, supply_max_kpa=400.0, pneumatic=valves)
    p0_kpa, command = (0.0, 300.0) if inlet else (200.0, 0.0)
    n = 300
    angle0_deg = math.degrees(INDEX_PRBM.pressure_gain_nm_per_kpa * p0_kpa / INDEX_PRBM.stiffness_nm_per_rad)
    _, chamber = simulate(finger, np.full(n, command), RATE_HZ, substeps=1, angle0_deg=angle0_deg,
                          chamber0_kpa=p0_kpa)
    t_s = np.arange(n) / RATE_HZ
    expected = independent_kpa(valves, INDEX_PRBM, t_s, p0_kpa, inlet)
    # while the valve is held fully open: filling until within 20 kPa of the command, venting throughout
    within = expected < command - 20.0 if inlet else np.ones(n, dtype=bool)
    assert within.sum() > 15
    np.testing.assert_allclose(chamber[within], expected[within], rtol=0.01, atol=1.0)
    assert np.ptp(chamber[within]) > 50.0  # it moved: the test compares a real transient


def test_the_regulator_settles_within_its_deadband_and_a_nan_command_vents() -> None:
    finger = SimFinger(INDEX_PRBM, pneumatic=pneumatic_valves())
    sim = Simulator([finger], sample_rate_hz=100.0, seed=3)
    chamber = []
    for _ in range(150):
        sim.command_kpa[0] = 60.0
        sim.step()
        chamber.append(float(sim.outputs.chamber_pressure_kpa[0]))
    settled = np.array(chamber[100:])
    assert abs(float(np.mean(settled)) - 60.0) < 2.0
    assert np.ptp(settled) < 6.0  # held: no limit cycle beyond the deadband and a minimum pulse
    static_rad = INDEX_PRBM.pressure_gain_nm_per_kpa * np.mean(settled) / INDEX_PRBM.stiffness_nm_per_rad
    assert float(sim.outputs.angle_deg[0]) == pytest.approx(math.degrees(static_rad), abs=2.0)
    for _ in range(150):
        sim.command_kpa[0] = math.nan
        sim.step()
    assert abs(float(sim.outputs.chamber_pressure_kpa[0])) < 1.0
    assert np.isfinite(sim.outputs.angle_deg[0])


def test_first_order_mode_ignores_the_pneumatic_fields() -> None:
    """Default behaviour is unchanged: valve_model 0 runs the effects' lag and dead time,
    whatever the pneumatic fields hold; the pneumatic mode does not."""
    lagged = dataclasses.replace(INDEX_PRBM, effects=Effects(valve_lag_tau_s=0.03, dead_time_s=0.005))
    finger = SimFinger(lagged)
    garbage = dataclasses.replace(finger, pneumatic=PneumaticValves(valve_model=VALVE_FIRST_ORDER,
                                                                     supply_kpa=math.nan, step_us=0))
    command = np.r_[np.zeros(5), np.full(60, 80.0), np.zeros(35)]
    plain = simulate(finger, command, 100.0)
    ignored = simulate(garbage, command, 100.0)
    np.testing.assert_array_equal(plain[0], ignored[0])
    np.testing.assert_array_equal(plain[1], ignored[1])
    pneumatic = simulate(dataclasses.replace(finger, pneumatic=pneumatic_valves()), command, 100.0)
    assert np.max(np.abs(pneumatic[1] - plain[1])) > 5.0


@pytest.mark.parametrize("change", [{"supply_kpa": math.nan}, {"step_us": 0}, {"step_us": 300},
                                    {"regulator_period_us": 1030}, {"polytropic_index": 2.0},
                                    {"inlet_critical_ratio": 1.0}, {"min_pulse_us": 20000},
                                    {"valve_model": 7}])
def test_a_bad_pneumatic_config_is_refused(change: dict[str, float]) -> None:
    with pytest.raises(ConfigError, match="model"):
        Simulator([SimFinger(INDEX_PRBM, pneumatic=dataclasses.replace(pneumatic_valves(), **change))])


def test_a_pneumatic_profile_runs_every_finger_on_the_boards_pneumatics(tmp_path: Path) -> None:
    profile = load_profile(write_pneumatic_profile(tmp_path))
    assert profile.simulation["valve_model"] == "pneumatic"
    sim = hand_simulator(profile)
    assert all(f.pneumatic.valve_model == VALVE_PNEUMATIC for f in sim.fingers)
    assert all(f.pneumatic == pneumatic_valves() for f in sim.fingers)
    assert all(f.pneumatic.valve_model == VALVE_FIRST_ORDER for f in hand_simulator(load_profile()).fingers)


@pytest.mark.parametrize(("block", "message"), [
    ("    supply_kpa: 200\n    exhaust_conductance_dm3_per_s_bar: 0.2\n", None),
    ("    supply_kpa: -5\n", r"p.yaml:8: simulation.pneumatics.supply_kpa = -5 kPa is out of range"),
    ("    supply_kpa: 200\n    supply_kp: 3\n", r"p.yaml:9: .*supply_kp.*supply_kpa"),
    ("    pwm_period_us: 1025\n", r"p.yaml:8: simulation.pneumatics.pwm_period_us = 1025 must be a whole"),
])
def test_profile_pneumatics_keys_are_checked(tmp_path: Path, block: str, message: str | None) -> None:
    path = tmp_path / "p.yaml"
    path.write_text(f"profile: p\nprotocol_version: 1\ninclude: {PROFILE_DIR / 'sim.yaml'}\ntransport:\n"
                    f"  kind: sim\nsimulation:\n  pneumatics:\n{block}  valve_model: pneumatic\n")
    if message is None:
        valves = hand_simulator(load_profile(path)).fingers[0].pneumatic
        assert (valves.supply_kpa, valves.exhaust_conductance_dm3_per_s_bar) == (200.0, 0.2)
        assert valves.valve_model == VALVE_PNEUMATIC
    else:
        with pytest.raises(UserError, match=message):
            load_profile(path)


def test_the_physics_and_the_regulator_are_the_boards_own_source() -> None:
    """One source of truth: the extension compiles board/plant/pneumatics.c and
    board/core/regulator.c; nothing in csrc/ defines their functions again."""
    ours = (ROOT / "csrc" / "rtcore_pneumatic.c").read_text()
    assert '#include "pneumatics.c"' in ours and '#include "regulator.c"' in ours
    for path in (ROOT / "csrc").glob("*.c"):
        text = path.read_text()
        assert not re.search(r"^\w[\w\s\*]*\b(pneumatics_step|regulator_step)\s*\(", text, re.M), path.name


def test_the_defaults_are_the_host_firmwares_plant_and_regulator() -> None:
    """rtcore.pneumatic's defaults against the numbers in board/plant/plant.c and board/core/board.c."""
    plant = (ROOT / "board" / "plant" / "plant.c").read_text()
    board = (ROOT / "board" / "core" / "board.c").read_text()
    d = PneumaticValves()

    def number(text: str, pattern: str) -> float:
        found = re.search(pattern + r"\s*=\s*([-0-9.e]+)", text)
        assert found, pattern
        return float(found.group(1))

    assert d.supply_kpa == number(plant, r"p\.supply_kpa")
    assert d.atmosphere_kpa == number(plant, r"p\.atmosphere_kpa")
    assert d.temperature_k == number(plant, r"p\.temperature_k")
    assert d.polytropic_index == number(plant, r"p\.polytropic_index")
    assert d.dead_volume_ml == number(plant, r"p\.dead_volume_m3")
    for side in ("inlet", "exhaust"):
        assert getattr(d, f"{side}_conductance_dm3_per_s_bar") == number(
            plant, rf"p\.{side}\.sonic_conductance_m3_per_s_pa")
        assert getattr(d, f"{side}_critical_ratio") == number(plant, rf"p\.{side}\.critical_ratio")
        assert getattr(d, f"{side}_open_delay_s") == number(plant, rf"p\.{side}\.open_delay_s")
        assert getattr(d, f"{side}_close_delay_s") == number(plant, rf"p\.{side}\.close_delay_s")
    assert d.regulator_period_us == number(board, r"c\.inner_period_us")
    for name in ("deadband_kpa", "gain_permille_per_kpa", "pwm_period_us", "min_pulse_us", "vent_below_kpa"):
        assert getattr(d, name) == number(board, rf"c\.regulator\.{name}")


def test_a_pwm_pulse_opens_the_valve_for_its_duty_after_the_valves_delays() -> None:
    """The board's PWM as the host HAL drives it: at 50 kPa with 55 commanded, the regulator
    asks for 300 ‰ (60 ‰/kPa × 5 kPa, also the 3 ms minimum pulse), loaded at the PWM period's
    start: the inlet opens 2 ms later, is told to shut at 3 ms and shuts 1.5 ms after that.
    The overshoot then asks for the exhaust, which waits for the next period (10 ms) and its
    own 2 ms. A chamber that does not move (N = 0) shows each of those instants."""
    still = dataclasses.replace(INDEX_PRBM, pressure_gain_nm_per_kpa=0.0)
    finger = SimFinger(still, pneumatic=pneumatic_valves())
    _, chamber = simulate(finger, np.full(20, 55.0), RATE_HZ, substeps=1, chamber0_kpa=50.0)
    assert chamber[1] == 50.0  # 1 ms: the inlet is still opening
    assert chamber[2] < 50.5 < chamber[3] < chamber[4]  # open from 2 ms
    np.testing.assert_array_equal(chamber[5:12], chamber[5])  # shut from 4.5 ms until 12 ms
    assert chamber[5] > 56.0  # the pulse overshot the deadband ...
    assert chamber[13] < chamber[12]  # ... so the exhaust opens 2 ms into the next period
    # a duty asked for mid-period (600 ‰ at 2 ms: 10 kPa of error) waits for the next period
    _, chamber = simulate(finger, np.r_[np.full(2, 50.0), np.full(18, 60.0)], RATE_HZ, substeps=1,
                          chamber0_kpa=50.0)
    np.testing.assert_array_equal(chamber[:13], 50.0)
    assert chamber[13] > 50.5
