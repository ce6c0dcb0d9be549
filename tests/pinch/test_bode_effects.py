"""The effects ablation of impedance mode (hand_service.pinch.bode_effects): one effect
taken out of one finger's model, and the free finger left alone about its reference."""

from __future__ import annotations

import dataclasses

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import Profile
from hand_service.pinch.bode_effects import at_rest, with_effect, without_effect
from hand_service.pinch.mismatch import NONE

LOOP = {"hysteresis": {"torque_nm": 0.005, "travel_deg": 0.5}, "pressure_stiffening": {"gain": 0.02}}


def test_one_effect_leaves_one_fingers_model(truth: Profile) -> None:
    fingers = [dataclasses.replace(f, model=f.model.with_changes(effects={**f.model.effects, **LOOP}))
               for f in truth.fingers]
    both = dataclasses.replace(truth, fingers=fingers)
    out = without_effect(both, "index", "hysteresis")
    assert "hysteresis" not in out.finger("index").model.effects
    assert out.finger("index").model.effects["pressure_stiffening"] == LOOP["pressure_stiffening"]
    assert out.finger("thumb").model.effects["hysteresis"] == LOOP["hysteresis"]
    back = with_effect(out, "index", "hysteresis", LOOP["hysteresis"])
    assert back.finger("index").model.effects == both.finger("index").model.effects


def test_the_exact_model_rests_on_its_reference(truth: Profile) -> None:
    k_set = gain_limits(truth.finger("index").model)[0]
    mean_deg, angle_pp_deg, chamber_pp_kpa = (float(c) for c in at_rest(truth, truth, "index", k_set, NONE)
                                              .split(" | "))
    assert abs(mean_deg - 80.0) < 0.5
    assert 0.0 < angle_pp_deg < 1.5 and 0.0 < chamber_pp_kpa < 3.0  # the sensor's noise, no swing
