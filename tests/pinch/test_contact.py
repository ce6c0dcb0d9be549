"""The contact and friction model: the friction cone's stick and slip, the pads' tilt, the
person's hand until release, and the statistics and tuning rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hand_service.config.profile import Profile
from hand_service.pinch.objects import CHIP, COIN, SCREWDRIVER, Placements
from hand_service.pinch.plant import (
    HAND_STIFFNESS_N_PER_M,
    HELD,
    RELEASE_S,
    SLIPPED,
    ObjectArrays,
    PinchPlant,
)
from hand_service.pinch.stats import wilson_interval
from hand_service.pinch.trials import CLOSING_S, PAIRS, Cell, finger_arrays, pair_gap_m, run_cells
from hand_service.pinch.tuning import Rule, window


def plant(truth: Profile, obj: object, placements: Placements, release_s: float = 0.0) -> PinchPlant:
    n = len(placements.width_m)
    fingers = finger_arrays(truth, [PAIRS[0]] * n)
    return PinchPlant(fingers, ObjectArrays.build([obj], [placements]), pair_gap_m(fingers.lever_arm_m), 1e-3,
                      release_s=release_s)


def squeeze(p: PinchPlant, overlap_m: float) -> np.ndarray:
    """Both pads pressed overlap_m into the object: their normal forces."""
    lever = p.f.lever_arm_m
    closing = p.gap_m - p.o.width_m + 2 * overlap_m
    p.angle_rad[:] = (closing / lever.sum(axis=1))[:, None]
    return np.full((len(closing), 2), 2500.0 * overlap_m)


def test_friction_cone_sticks_inside_and_slips_outside(truth: Profile) -> None:
    p = plant(truth, SCREWDRIVER, Placements.nominal(SCREWDRIVER, 2))
    p.release()
    normal = squeeze(p, 0.0)
    normal[0] = 4.0  # enough torsional friction for the handle's torque
    normal[1] = 0.5  # not enough
    p.swing.angle_rad[:] = p.gravity_torque_nm() / p.swing.stiffness_nm_per_rad  # bent, at rest
    load, limits = p.demand(normal)
    ratio = np.sqrt(((load / limits) ** 2).sum(axis=1))
    assert ratio[0] < 1.0 < ratio[1]
    for _ in range(500):
        p._grip(normal)
    assert p.outcome[0] == HELD and p.slip_m[0] == 0.0  # stick: not a micrometre of creep
    assert p.outcome[1] == SLIPPED and p.rotation_rad[1] > 0.0 and p.slip_m[1] > 0.0


def test_the_coins_thin_rim_tilts_the_pads_more_the_harder_they_press(truth: Profile) -> None:
    placements = Placements.nominal(COIN, 3)
    placements.lateral_m[:] = [0.0, 0.002, 0.002]
    p = plant(truth, COIN, placements)
    tilt = p.tilt_rad(np.array([[1.0, 1.0], [1.0, 1.0], [5.0, 5.0]]))
    assert np.all(tilt[0] == 0.0)
    assert np.all(tilt[2] > tilt[1]) and np.all(tilt[1] > 0.0)
    # a broad face (the chip's) keeps the pad square whatever the force
    chip = Placements.nominal(CHIP, 1)
    chip.lateral_m[:] = 0.002
    assert np.all(plant(truth, CHIP, chip).tilt_rad(np.array([[5.0, 5.0]])) == 0.0)


def test_before_release_the_persons_hand_holds_the_object(truth: Profile) -> None:
    p = plant(truth, COIN, Placements.nominal(COIN, 1))
    lever = p.f.lever_arm_m[0]
    p.angle_rad[0] = [(p.gap_m[0] - p.o.width_m[0]) / lever.sum() + 0.05, 0.0]  # only the thumb reaches
    depth, _ = p._overlaps()
    assert depth[0, 0] > 0.0 and depth[0, 1] < 0.0  # the hand takes the thumb's push
    p.release()
    depth, _ = p._overlaps()
    # alone, the thumb pushes the coin away: no grip
    assert depth[0, 0] == pytest.approx(depth[0, 1]) and depth[0, 0] < 0.0


def test_the_persons_hand_opens_over_the_release_time(truth: Profile) -> None:
    p = plant(truth, COIN, Placements.nominal(COIN, 1), release_s=0.25)
    assert p.hand_stiffness_n_per_m == HAND_STIFFNESS_N_PER_M
    p.release()
    for _ in range(125):
        p.advance(np.zeros((1, 2)))
    assert p.hand_stiffness_n_per_m == pytest.approx(HAND_STIFFNESS_N_PER_M / 2.0)
    for _ in range(126):
        p.advance(np.zeros((1, 2)))
    assert p.hand_stiffness_n_per_m == 0.0


def test_a_gradual_release_does_not_spike_the_pad_force(truth: Profile) -> None:
    """Thumb and middle on a chip at one pressure: the stronger middle finger presses the
    chip into the person's hand; let go at once, the pads' force overshoots where it
    settles; let go over RELEASE_S, it moves there without overshoot."""
    cells = [Cell(("thumb", "middle"), CHIP, "pressure", np.array([60.0]), Placements.nominal(CHIP, 1))]
    release_tick = round(CLOSING_S * truth.control.rate_hz)
    overshoot = {}
    for release_s in (0.0, RELEASE_S):
        force = run_cells(truth, truth, cells, 3, record=(0,), release_s=release_s).traces[0].normal_n
        overshoot[release_s] = force[release_tick:release_tick + 100].max() / force[-1] - 1.0
    assert overshoot[0.0] > 0.1
    assert overshoot[RELEASE_S] < 0.03


def test_chip_strength_follows_its_weibull_distribution() -> None:
    rng = np.random.default_rng(1)
    breaks = Placements.draw(CHIP, 20000, rng).break_force_n
    assert abs(breaks.mean() - 1.58) < 0.02  # the mean of the measured chips (docs/replicate.md)
    assert np.all(np.isinf(Placements.draw(COIN, 5, rng).break_force_n))


@pytest.mark.parametrize(("successes", "trials", "low", "high"),
                         [(8, 10, 0.4902, 0.9433), (0, 10, 0.0, 0.2775), (100, 200, 0.4314, 0.5686)])
def test_wilson_interval(successes: int, trials: int, low: float, high: float) -> None:
    got = wilson_interval(successes, trials)
    assert math.isclose(got[0], low, abs_tol=1e-4) and math.isclose(got[1], high, abs_tol=1e-4)


def test_tuning_keeps_the_run_of_holding_setpoints_from_the_lowest() -> None:
    setpoints = np.arange(1.0, 9.0)
    assert window(setpoints, np.array([0, 0, 1, 1, 1, 0, 1, 1], dtype=bool)) == (3.0, 5.0)
    assert window(setpoints, np.zeros(8, dtype=bool)) is None


def test_the_margin_rule_takes_the_first_step_at_the_margin_and_stays_in_the_window() -> None:
    rule = Rule("margin", 1.5)
    assert rule.pick(0.15, 10.0, 0.05) == 0.25  # 0.225 N rounds up to the next 0.05 N step
    assert rule.pick(44.0, 200.0, 1.0) == 66.0
    assert rule.pick(67.0, 71.0, 1.0) == 71.0  # 100.5 kPa broke the chip on the tuning trial
    # the search cap does not move it (the middle rule's answer does)
    assert rule.pick(0.15, 10.0, 0.05) == rule.pick(0.15, 25.0, 0.05)
    assert Rule("middle").pick(0.15, 10.0, 0.05) != Rule("middle").pick(0.15, 25.0, 0.05)
