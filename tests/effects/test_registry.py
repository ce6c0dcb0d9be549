"""The effect library: the project's effects registered by name, their hooks the C model's
fields, and a lab's effect from its own package (tests/fixtures/outside_effect, a
distribution with a `hand_service.effects` entry point) taken up by the model file, the
simulator and `simulate` without project code changed."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.effects import FieldEffect, registry
from hand_service.errors import UserError
from hand_service.simulator import sim_finger
from rtcore import Effects
from rtcore.sim import SimFinger, simulate_angle

SITE = Path(__file__).resolve().parents[1] / "fixtures" / "outside_effect" / "site"
EIGHT = ("valve_lag", "dead_time", "coulomb_friction", "cubic_stiffness", "gravity", "asymmetric_stiffness",
         "quadratic_damping", "pressure_deadzone")
PAPER = FingerModel(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
                    pressure_gain_nm_per_kpa=0.0119, lever_arm_m=0.04)


@pytest.fixture
def lab_package(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """The lab's distribution importable, as `pip install` would leave it."""
    monkeypatch.syspath_prepend(str(SITE))
    registry.refresh()
    yield
    monkeypatch.undo()
    sys.modules.pop("lab_effects", None)
    registry.refresh()


def test_the_eight_are_the_c_models_fields_in_their_order() -> None:
    """(and searched by diagnose; contact, a term of the C model too, only behind the screen)"""
    names = tuple(e.name for e in fx.LIBRARY)
    assert names[:8] == EIGHT
    fields = {f.name for f in dataclasses.fields(Effects)}
    for name in EIGHT:
        effect = fx.BY_NAME[name]
        assert isinstance(effect, FieldEffect) and effect.rtcore_field in fields
        assert effect.lower <= effect.neutral <= effect.upper and effect.searched
        assert not effect.admitted_by_screen
    assert fx.BY_NAME["contact"].admitted_by_screen and fx.BY_NAME["contact"] in fx.SEARCHED


def test_a_field_effects_hook_sets_its_field_and_reads_it_back() -> None:
    finger = SimFinger(prbm=PAPER.prbm("test", force_point=False))
    for name in EIGHT:
        effect = fx.BY_NAME[name]
        value = effect.neutral + 0.5 * (effect.upper - effect.neutral)
        changed = effect.apply(finger, {effect.param: value})
        assert effect.read(changed) == value
        assert getattr(fx.to_rtcore({name: {effect.param: value}}), effect.rtcore_field) == value
        assert effect.read(finger) == effect.neutral  # the original untouched


def test_a_model_file_refuses_an_unknown_effect() -> None:
    with pytest.raises(UserError, match="unknown key 'end_stop' in effects"):
        fx.parse_effects({"end_stop": {"stiffness_nm_per_rad": 1.0}}, "m.yaml")
    with pytest.raises(UserError, match="did you mean 'gravity'"):
        fx.parse_effects({"gravty": {"torque_nm": 0.1}}, "m.yaml")


def test_a_labs_effect_is_discovered_through_its_entry_point(lab_package: None) -> None:
    stop = fx.BY_NAME["end_stop"]
    assert tuple(e.name for e in fx.LIBRARY)[:8] == EIGHT and fx.LIBRARY[-1] is stop
    assert "lab_effects:END_STOP" in registry.origin("end_stop")
    parsed = fx.parse_effects({"end_stop": {"stiffness_nm_per_rad": 2.0, "stop_angle_deg": 40.0}}, "m.yaml")
    assert parsed == {"end_stop": {"stiffness_nm_per_rad": 2.0, "stop_angle_deg": 40.0}}
    with pytest.raises(UserError, match="stop_angle_deg = 400 is out of range"):
        fx.parse_effects({"end_stop": {"stiffness_nm_per_rad": 2.0, "stop_angle_deg": 400}}, "m.yaml")
    assert fx.to_rtcore(parsed) == Effects()  # not a term of the controller's model


def test_a_labs_effect_is_simulated_by_its_hook(lab_package: None) -> None:
    """The stop holds the finger back past its angle only: below it the run is the plain
    one, above it the static balance N·p = k·θ + K·(θ − θs) of the C simulator."""
    stop = {"end_stop": {"stiffness_nm_per_rad": 2.0, "stop_angle_deg": 30.0}}
    model = dataclasses.replace(PAPER, effects=stop)
    plain = simulate_angle(sim_finger(PAPER), np.full(400, 10.0), 100.0, 1)
    stopped = simulate_angle(sim_finger(model), np.full(400, 10.0), 100.0, 1)
    assert np.max(plain) < 30.0 and np.allclose(plain, stopped, atol=1e-9)
    pressure_kpa = 120.0
    held = simulate_angle(sim_finger(model), np.full(800, pressure_kpa), 100.0, 1)[-1]
    k, n, stop_k, stop_rad = 0.57, 0.0119, 2.0, np.radians(30.0)
    balance_rad = (n * pressure_kpa + stop_k * stop_rad) / (k + stop_k)
    assert held == pytest.approx(np.degrees(balance_rad), abs=1e-3)


def test_two_effects_of_one_name_are_refused() -> None:
    clash = FieldEffect("gravity", "another", fx.BY_NAME["gravity"].parameters,
                        rtcore_field="gravity_torque_nm")
    with pytest.raises(UserError, match="clashes"):
        registry.register(clash, "a lab")


def test_simulate_takes_a_labs_effect_from_the_environment(tmp_path: Path) -> None:
    """The command line, the package installed beside the project: nothing else."""
    env = {**os.environ, "PYTHONPATH": str(SITE)}
    out = tmp_path / "stop.csv"
    run = subprocess.run([sys.executable, "-m", "hand_service.cli", "simulate", "--effect", "end_stop=2",
                          "--duration", "5", "-o", str(out), "--truth", str(tmp_path / "truth.json")],
                         env=env, capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr
    assert "hidden end_stop: {'stiffness_nm_per_rad': 2.0}" in run.stdout
    without = subprocess.run([sys.executable, "-m", "hand_service.cli", "simulate", "--effect", "end_stop=2",
                              "--duration", "5", "-o", str(out)],
                             env={k: v for k, v in env.items() if k != "PYTHONPATH"}, capture_output=True,
                             text=True, timeout=120, check=False)
    assert without.returncode != 0 and "unknown effect 'end_stop'" in without.stderr


@pytest.mark.slow
def test_diagnose_names_a_labs_effect(tmp_path: Path) -> None:
    """A stop concealed at three times the noise is named, its K within 5 %."""
    env = {**os.environ, "PYTHONPATH": str(SITE)}
    cli = [sys.executable, "-m", "hand_service.cli"]
    rec, nominal, truth, out = (tmp_path / n for n in ("stop.csv", "nominal.yaml", "truth.json", "d.json"))
    subprocess.run([*cli, "simulate", "--effect", "end_stop", "--conceal", "3", "--excitation", "sweep",
                    "--seed", "1", "-o", str(rec), "--nominal-model", str(nominal), "--truth", str(truth)],
                   env=env, check=True, capture_output=True, timeout=300)
    subprocess.run([*cli, "diagnose", str(rec), "--model", str(nominal), "--json", str(out), "--quiet"],
                   env=env, check=True, capture_output=True, timeout=1200)
    import json
    found = json.loads(out.read_text())["effects"]
    hidden = json.loads(truth.read_text())["hidden_effects"]["end_stop"]["stiffness_nm_per_rad"]
    assert found[0]["name"] == "end_stop"
    assert found[0]["params"]["stiffness_nm_per_rad"] == pytest.approx(hidden, rel=0.05)


def test_every_effect_at_neutral_is_the_plain_model() -> None:
    assert fx.to_rtcore({name: {fx.BY_NAME[name].param: fx.BY_NAME[name].neutral} for name in EIGHT}) \
        == Effects()


def test_contacts_three_parameters_are_its_c_fields() -> None:
    block = fx.parse_effects({"contact": {"stiffness_nm_per_radn": 2.0, "onset_deg": 30}}, "m.yaml")
    effects = fx.to_rtcore(block)
    assert (effects.contact_stiffness_nm_per_radn, effects.contact_onset_deg, effects.contact_exponent) \
        == (2.0, 30.0, 1.0)  # the exponent at its default: a linear stop
