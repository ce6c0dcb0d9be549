"""The per-pair protocol: each finger pair tuned on its own, the operator's written rule
(3 of 3 placed grasps) and the human-like one (one centred grasp), and the operator's
fallback where no setpoint holds."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.config.profile import Profile
from hand_service.pinch.objects import CHIP, Placements
from hand_service.pinch.tuning import HAND_RULE, HUMAN_RULE, OPERATOR_RULE, fallback, tune

INDEX, MIDDLE = ("thumb", "index"), ("thumb", "middle")


def test_the_rules_say_what_they_do() -> None:
    assert HAND_RULE.describe() == "lowest holding x 1.5"  # the default run's, unchanged
    assert OPERATOR_RULE.describe() == ("lowest holding x 1.25, holding in 3 of 3 placed grasps, "
                                        "per finger pair")
    assert HUMAN_RULE.describe() == "lowest holding x 1.5, per finger pair"
    assert OPERATOR_RULE.where == "each finger pair, 3 grasps placed by hand"


def test_regrasped_placements_keep_one_nominal_specimen() -> None:
    grasps = Placements.regrasped(CHIP, 3, np.random.default_rng(2))
    assert np.all(grasps.width_m == CHIP.width_m) and len(set(grasps.break_force_n)) == 1
    assert len(set(grasps.axial_m)) == 3
    tiled = grasps.tiled(4)
    assert np.array_equal(tiled.axial_m[3:6], grasps.axial_m) and len(tiled.lateral_m) == 12


def test_fallback_takes_the_most_held_else_the_firmest_unbroken() -> None:
    setpoints = np.arange(50.0, 56.0)
    assert fallback(setpoints, np.array([0, 1, 2, 2, 0, 0]), np.zeros(6, bool)) == 52.0
    broke = np.array([0, 0, 0, 1, 1, 1], dtype=bool)
    assert fallback(setpoints, np.zeros(6, int), broke) == 52.0
    assert fallback(setpoints, np.zeros(6, int), np.zeros(6, bool)) == 55.0


def test_per_pair_tuning_gives_each_pair_its_own_setpoint(truth: Profile) -> None:
    """On the chip: tuned per pair, the index's setpoints are the once-per-object ones;
    on thumb and middle the stronger middle finger presses a centred median chip into the
    person's hand before the thumb reaches it, so only a narrow band of pressures, below
    any that holds on thumb and index, holds it (and none if the hand let go at once)."""
    once = tune(truth, truth, 5, (CHIP,), HAND_RULE, (INDEX, MIDDLE))
    assert once[("middle", "chip", "pressure")] is once[("index", "chip", "pressure")]
    mine = tune(truth, truth, 5, (CHIP,), HUMAN_RULE, (INDEX, MIDDLE))
    assert mine[("index", "chip", "pressure")] == once[("index", "chip", "pressure")]
    middle = mine[("middle", "chip", "pressure")]
    assert middle.finger == "middle" and middle.holds
    low_kpa, high_kpa, _ = middle.in_own_unit()
    index_low_kpa = once[("index", "chip", "pressure")].in_own_unit()[0]
    assert high_kpa - low_kpa <= 3.0 and high_kpa < index_low_kpa
    force = mine[("middle", "chip", "force")]
    assert force.holds and force.setpoint_n == pytest.approx(once[("middle", "chip", "force")].setpoint_n)
