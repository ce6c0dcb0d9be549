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


def test_a_loop_the_finger_lacks_stays_out_of_impedance_unless_asked(truth: Profile) -> None:
    """A false positive, a loop in the model the PRBM finger lacks, at 0.1 K_max: with
    control.force_estimate_hysteresis off (the default) the free finger rests as without the
    loop; turned on, the loop's copy is uncancelled positive feedback and the finger swings
    (less since the force loop's integral gain falls with K below K_max: 2.5 times the plain
    swing at 0.1 K_max, 2.7 at 0.3, 1.7 at K_max; docs/results.md §12.50)."""
    k_set = 0.1 * gain_limits(truth.finger("index").model)[0]
    false_loop = with_effect(truth, "index", "hysteresis", {"torque_nm": 0.005, "travel_deg": 0.5})
    asked = dataclasses.replace(false_loop, control=dataclasses.replace(truth.control,
                                                                        force_estimate_hysteresis=True))
    plain = at_rest(truth, truth, "index", k_set, NONE)
    assert at_rest(truth, false_loop, "index", k_set, NONE) == plain
    plain_pp_deg = float(plain.split(" | ")[1])
    assert float(at_rest(truth, asked, "index", k_set, NONE).split(" | ")[1]) > 2.0 * plain_pp_deg
