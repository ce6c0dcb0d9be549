"""diagnose searches the library's searched effects, contact, hysteresis and creep behind the
screen (search/admission.py); `--search` adds one it leaves out by default (valve_vent_lag,
pressure_stiffening) or asks for one behind the screen by name, fitted whatever the screen
says, by the same tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.excitations import EXCITATIONS
from hand_service.diagnose.concealed.generator import full_pressure_kpa, generate, perturb, record
from hand_service.diagnose.engine import diagnose, searched, shape_only
from hand_service.errors import UserError


def test_the_default_search_is_the_searched_effects() -> None:
    assert searched(()) == [e.name for e in fx.SEARCHED]
    assert "valve_vent_lag" not in searched(()) and "contact" in searched(())
    assert "creep" in searched(()) and "pressure_stiffening" not in searched(())
    assert searched(["valve_vent_lag", "valve_vent_lag"])[-1:] == ["valve_vent_lag"]
    with pytest.raises(UserError, match="--search stiffening: unknown effect"):
        searched(["stiffening"])


def test_a_concealed_pressure_stiffening_is_named_when_searched() -> None:
    """Concealed at 0.8 times the noise on the project's generator: named first, its gain
    within 10 % (without it searched, the eight's nearest stand-in is named: docs/results.md)."""
    model = load_profile(None).finger("index").model
    c = generate(model, {"pressure_stiffening": None}, "steps", noise_deg=0.5, seed=1, conceal_ratio=0.8)
    true = c.hidden["pressure_stiffening"]["gain"]
    found = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0, also=("pressure_stiffening",))
    assert found.effects[0].name == "pressure_stiffening"
    assert found.effects[0].value == pytest.approx(true, rel=0.1)


@dataclass(frozen=True)
class StopRecording:
    """sim.yaml's index finger on the project's generator's steps, a contact in its truth;
    the lab's nominal (k, B, N off by up to 10 %) without it."""

    nominal: FingerModel
    t_s: np.ndarray
    command_kpa: np.ndarray
    angle_deg: np.ndarray


def stop_recording(stop: dict[str, float]) -> StopRecording:
    model = load_profile(None).finger("index").model
    rng = np.random.default_rng(2)
    command = EXCITATIONS["steps"](full_pressure_kpa(model), 30.0, 100.0, rng)
    measured, _ = record(model.with_changes(effects={**model.effects, "contact": stop}), command, 100.0,
                         0.3, 0.122, 2)
    return StopRecording(perturb(model, 0.1, rng), np.arange(command.size) / 100.0, command, measured)


def test_a_contact_whose_onset_the_model_gives_is_searched_there() -> None:
    """A lab that knows where its object sits writes the contact's onset with K at 0 ("none"):
    diagnose searches for the contact there (requested.shape_only) and fits K with the onset
    held at the lab's value (Problem.given_effects), where the library's default onset, 45°,
    would leave the stop's torque unexplained. The stop at 30°."""
    stop = {"stiffness_nm_per_radn": 0.3, "onset_deg": 30.0, "exponent": 1.5}
    r = stop_recording(stop)
    lab = {**stop, "stiffness_nm_per_radn": 0.0}
    given = r.nominal.with_changes(effects={**r.nominal.effects, "contact": lab})
    assert shape_only(given.effects, "contact") and not shape_only(r.nominal.effects, "contact")
    found = diagnose(given, r.t_s, r.command_kpa, r.angle_deg, 100.0, also=("contact",))
    assert found.effects[0].name == "contact"
    assert found.effects[0].value == pytest.approx(0.3, rel=0.15)


def test_a_contact_is_named_with_its_onset_and_exponent_fitted() -> None:
    """Without its onset in the model, a stop met at 60° (the library's default onset is
    45°): with contact asked for, diagnose fits its stiffness, onset and exponent together
    (Effect.shape_parameters, from shape_start's onset at a high quantile of the angle) and
    names it with all three. By default too: behind the screen, which sees the contact at
    its start's onset, a cubic spring screens ahead of it and is picked first, the contact
    beside it gains more than the spring did, and the search runs again with the contact
    fitted from the first round (search/late_stand_in.py)."""
    r = stop_recording({"stiffness_nm_per_radn": 1.0, "onset_deg": 60.0, "exponent": 1.5})
    for also in ((), ("contact",)):
        found = diagnose(r.nominal, r.t_s, r.command_kpa, r.angle_deg, 100.0, also=also)
        assert [e.name for e in found.effects] == ["contact"], (also, found.warnings)
        params = found.effects[0].params
        assert params["onset_deg"] == pytest.approx(60.0, abs=2.0)
        assert params["exponent"] == pytest.approx(1.5, abs=0.2)
        assert params["stiffness_nm_per_radn"] == pytest.approx(1.0, rel=0.15)
        assert found.refit_model().effects["contact"] == pytest.approx(params)


def test_a_loop_is_named_with_its_travel_fitted() -> None:
    """A Dahl loop of 10° travel (the library's default start is 5°) on the project's
    generator's sweep: searched for, its torque and travel are fitted together (a
    FingerEffect's shape read back through read_parameter), both within 5 %."""
    model = load_profile(None).finger("index").model
    rng = np.random.default_rng(2)
    command = EXCITATIONS["sweep"](full_pressure_kpa(model), 30.0, 100.0, rng)
    loop = {"torque_nm": 0.02, "travel_deg": 10.0}
    measured, _ = record(model.with_changes(effects={**model.effects, "hysteresis": loop}), command, 100.0,
                         0.3, 0.122, 2)
    found = diagnose(perturb(model, 0.1, rng), np.arange(command.size) / 100.0, command, measured, 100.0,
                     also=("hysteresis",))
    assert [e.name for e in found.effects] == ["hysteresis"]
    assert found.effects[0].params == pytest.approx(loop, rel=0.05)
    assert set(found.effects[0].shape_std) == {"travel_deg"}


def test_a_damped_contact_is_named_with_its_damper_fitted() -> None:
    """A stop met at 60° with a Kelvin-Voigt damper in contact (0.02 N·m·s/rad, several times
    the finger's B): searched for, the damper is fitted beside K, θc and n (from 0, its
    neutral), each close to the truth's; the undamped contact's fit would leave the damper's
    torque as a residual."""
    stop = {"stiffness_nm_per_radn": 1.0, "onset_deg": 60.0, "exponent": 1.5, "damping_nms_per_rad": 0.02}
    r = stop_recording(stop)
    found = diagnose(r.nominal, r.t_s, r.command_kpa, r.angle_deg, 100.0, also=("contact",))
    assert [e.name for e in found.effects] == ["contact"]
    params = found.effects[0].params
    assert params["damping_nms_per_rad"] == pytest.approx(0.02, rel=0.25)
    assert params["stiffness_nm_per_radn"] == pytest.approx(1.0, rel=0.15)
    assert params["onset_deg"] == pytest.approx(60.0, abs=2.0)
