"""diagnose on concealed recordings: one representative per library effect (two in make
test, every one in make test-thorough), clean ones, and the honest answers
(insufficient_excitation, unexplained). The full battery is in test_battery.py (slow)."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.config import effects as fx
from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.excitations import REPRESENTATIVE as EXCITATION
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose
from hand_service.simulator import Contact, sim_finger
from rtcore.sim import Simulator

CONCEAL = 0.6  # the refitted plain model's residual is 0.6 x the noise
NOISE_DEG = 0.5


def index_model():
    return load_profile(None).finger("index").model


def run(hidden: dict, excitation: str, seed: int, **kwargs):
    c = generate(index_model(), hidden, excitation, noise_deg=NOISE_DEG, seed=seed, conceal_ratio=CONCEAL,
                 **kwargs)
    rate_hz = 1.0 / (c.t_s[1] - c.t_s[0])
    return c, diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, rate_hz)


def test_every_searched_effect_has_a_representative() -> None:
    """(the eight: the four searched behind the screen have their own tests)"""
    assert set(EXCITATION) == {e.name for e in fx.SEARCHED if not e.admitted_by_screen}


IN_MAKE_TEST = ("coulomb_friction", "gravity")  # the rest in make test-thorough (the slice's every effect:
# test_independent_battery.py)


@pytest.mark.parametrize("name", [n if n in IN_MAKE_TEST else pytest.param(n, marks=pytest.mark.thorough)
                                  for n in EXCITATION])
def test_concealed_effect_is_named_first_and_recovered(name: str) -> None:
    c, d = run({name: None}, EXCITATION[name], seed=11)
    assert 0.5 < c.concealment < 0.7  # concealed: below the noise once k, B, N are refitted
    assert d.verdict == "missing_physics", d.warnings
    assert d.effects[0].name == name
    spec = fx.BY_NAME[name]
    true = c.hidden[name][spec.param]
    assert abs(d.effects[0].value - true) <= 0.25 * abs(true - spec.neutral)
    assert d.rmse_deg["augmented"] < d.rmse_deg["refit"]
    assert d.effects[0].std < 0.25 * abs(true - spec.neutral)  # the uncertainty says it is known
    assert len(d.windows) > 0


@pytest.mark.parametrize(("excitation", "seed"), [("steps", 21), ("sweep", 22), ("steps", 23)])
def test_clean_recordings_with_wrong_parameters_give_no_effects(excitation: str, seed: int) -> None:
    c, d = run({}, excitation, seed)
    assert d.verdict in ("parameters_only", "consistent")
    assert d.effects == []
    assert d.rmse_deg["refit"] < d.rmse_deg["nominal"]
    for name in ("stiffness_nm_per_rad", "pressure_gain_nm_per_kpa"):
        assert d.to_json()["refit"][name] == pytest.approx(getattr(c.truth, name), rel=0.01)


def test_a_right_model_is_consistent() -> None:
    _, d = run({}, "steps", 24, perturbation=0.0)
    assert d.verdict == "consistent"
    assert d.effects == []


def test_500_hz_recording() -> None:
    c, d = run({"coulomb_friction": None}, "steps", 12, duration_s=12.0, rate_hz=500.0)
    assert d.problem.substeps == 0  # the simulator chooses its steps where friction needs them
    assert [e.name for e in d.effects][:1] == ["coulomb_friction"]
    true = c.hidden["coulomb_friction"]["torque_nm"]
    assert d.effects[0].value == pytest.approx(true, rel=0.25)


def test_lag_or_delay_is_insufficient_excitation_when_the_model_has_neither() -> None:
    """With no valve dynamics in the model, a small lag and a small delay look the same."""
    model = index_model().with_changes(effects={})
    c = generate(model, {"valve_lag": None}, "steps", noise_deg=NOISE_DEG, seed=13, conceal_ratio=CONCEAL)
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert d.verdict == "insufficient_excitation"
    assert d.effects == []
    assert any("valve_lag" in w and "dead_time" in w for w in d.warnings)


def test_single_slow_sine_cannot_separate_the_parameters() -> None:
    _, d = run({"valve_lag": 0.05}, "sine", 14)
    assert d.verdict == "insufficient_excitation"
    assert d.effects == []


def _pressed_into_an_object():
    """The simulator's finger pressing into an object past 50 deg (a linear spring)."""
    c = generate(index_model(), {}, "steps", noise_deg=NOISE_DEG, seed=3, perturbation=0.05)
    finger = sim_finger(c.truth, sensor_noise_deg=NOISE_DEG, contact=Contact(50.0, stiffness_n_per_m=300.0))
    sim = Simulator([finger], 100.0, 10, seed=3)
    angle = np.empty(c.pressure_kpa.size)
    angle[0] = sim.outputs.sensor_mv[0]
    for k in range(c.pressure_kpa.size - 1):
        sim.command_kpa[0] = c.pressure_kpa[k]
        sim.step()
        angle[k + 1] = sim.outputs.sensor_mv[0]
    return c, angle


def test_an_object_pressed_into_is_named_a_contact() -> None:
    """The default search (contact behind the screen) names it, at its onset and linear."""
    c, angle = _pressed_into_an_object()
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, angle, 100.0)
    assert [e.name for e in d.effects] == ["contact"], d.warnings
    assert d.effects[0].params["onset_deg"] == pytest.approx(50.0, abs=2.0)
    assert d.effects[0].params["exponent"] == pytest.approx(1.0, abs=0.2)


def test_physics_outside_the_eight_is_unexplained(monkeypatch: pytest.MonkeyPatch) -> None:
    """The same object with the eight alone searched: none of them explains it."""
    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    monkeypatch.setattr("hand_service.diagnose.engine.searched", lambda also: [
        name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen])
    c, angle = _pressed_into_an_object()
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, angle, 100.0)
    assert d.verdict == "unexplained"
    assert d.effects == []
    written = d.refit_model()  # what --write-model writes: the plain refit, nothing partial
    assert set(written.effects) == set(c.nominal.effects)
    assert written.stiffness_nm_per_rad == pytest.approx(d.refit.value("stiffness_nm_per_rad"))
    assert d.windows
    # the windows are where the finger is pressed into the object
    t_in_contact = c.t_s[c.angle_true_deg > 50.0]
    a, b, _ = d.windows[0]
    assert np.any((t_in_contact >= a - 0.5) & (t_in_contact <= b + 0.5))
    # structure is left, and the noise model took some of it: its spread is not called the noise
    assert d.structure_left
    assert d.noise_label != "noise" and "structure is left" in d.noise_label


def test_dry_friction_is_found_past_the_second_minimum() -> None:
    """Here a joint fit started from the Gauss-Newton step stops at Tc ≈ 0.002 N·m with B
    absorbing the rest (true Tc ≈ 0.0098 N·m): the grid scan must find the right basin."""
    c = generate(index_model(), {"coulomb_friction": None}, "steps", noise_deg=0.5, seed=5, conceal_ratio=0.8)
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert d.verdict == "missing_physics"
    assert d.effects[0].value == pytest.approx(c.hidden["coulomb_friction"]["torque_nm"], rel=0.1)


def test_two_hidden_effects_are_both_named() -> None:
    c = generate(index_model(), {"cubic_stiffness": 0.01, "pressure_deadzone": 1.0}, "steps", noise_deg=0.5,
                 seed=7)
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert d.verdict == "missing_physics"
    assert {e.name for e in d.effects} == {"cubic_stiffness", "pressure_deadzone"}


def test_timing_jitter_is_tolerated() -> None:
    from hand_service.diagnose.recording.timebase import regular_grid

    c = generate(index_model(), {"dead_time": None}, "steps", noise_deg=0.5, seed=9, conceal_ratio=CONCEAL)
    t = c.t_s + np.random.default_rng(0).uniform(-0.002, 0.002, c.t_s.size)  # ±20 % of the period
    grid = regular_grid(t, c.pressure_kpa, c.angle_deg, "jittered.csv")
    assert grid.rate_hz == pytest.approx(100.0, rel=1e-3) and grid.n_missing == 0
    d = diagnose(c.nominal, grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz)
    assert [e.name for e in d.effects] == ["dead_time"]


def test_skipped_ticks_are_held_and_left_out() -> None:
    """A daemon that skipped deadlines leaves rows out; the valves held the last command.
    On its grid again, the recording is diagnosed as if nothing were missing."""
    from hand_service.diagnose.recording.timebase import regular_grid

    c = generate(index_model(), {"dead_time": None}, "steps", noise_deg=0.5, seed=9, conceal_ratio=CONCEAL)
    keep = np.ones(c.t_s.size, dtype=bool)
    keep[[5, 6, 7, 800, 1500, 1501, 2400]] = False  # skipped ticks, the start-up's among them
    grid = regular_grid(c.t_s[keep], c.pressure_kpa[keep], c.angle_deg[keep], "skipped.csv")
    assert grid.n_missing == 7 and grid.t_s.size == c.t_s.size
    np.testing.assert_allclose(grid.t_s, c.t_s, atol=1e-9)
    assert grid.pressure_kpa[800] == c.pressure_kpa[799]  # the command held through the gap
    assert grid.missing[[5, 6, 7, 800, 1500, 1501, 2400]].all() and not grid.missing[799]
    d = diagnose(c.nominal, grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz, missing=grid.missing)
    assert [e.name for e in d.effects] == ["dead_time"]
