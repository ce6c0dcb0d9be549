"""The battery's judgement of whether a recording can tell gravity from a cubic spring
(tests/diagnose/truth/distinct.py), checked against the arithmetic it rests on and on two
battery cases."""

from __future__ import annotations

import numpy as np
import pytest

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.distinct import (
    distinct_visibility,
    left_over,
    library_torques,
    plain_sensitivities,
    torque_response_rad,
)
from tests.diagnose.truth.linear import DEG, LinearModel, response_deg

RATE_HZ = 100.0
MODEL = LinearModel(1e-4, 0.02, 0.5, 0.01)


def _left_of(effect: str, torque, command_kpa: np.ndarray) -> float:
    """What distinct_visibility leaves of `torque`(θ) acting on the finger driven by
    `command_kpa`, the noise RMS set so that what k, B and N (free) leave of the effect is
    1 × the noise."""
    plain_deg = response_deg(MODEL, command_kpa, RATE_HZ)
    effect_deg = torque_response_rad(MODEL, 0.01 * torque(plain_deg * DEG), RATE_HZ) / DEG  # small
    plain = plain_sensitivities(MODEL, command_kpa, RATE_HZ, 0.0)
    residual = effect_deg - plain @ np.linalg.lstsq(plain, effect_deg, rcond=None)[0]
    noise = float(np.sqrt(np.mean(residual**2)))
    return distinct_visibility(effect, plain_deg + effect_deg, command_kpa, RATE_HZ, MODEL, 0.0, noise)[1]


def test_one_way_bending_leaves_a_few_percent_of_gravity_beyond_a_cubic_spring() -> None:
    """Over 0 to 60°, what k, B and N leave of 1 − cos θ is θ³'s to within about a fifth of
    its RMS (a twentieth of its energy); bent both ways, the even 1 − cos θ is orthogonal
    to the odd θ³ and θ, and all of it but its mean (the sensor's offset's) is left."""
    t = np.arange(3000) / RATE_HZ
    command = 30.0 + 29.0 * np.sin(2 * np.pi * 0.1 * t)
    one_way = response_deg(MODEL, command, RATE_HZ)
    assert one_way.min() > -1.0 and one_way.max() > 55.0
    gravity = lambda theta: 1.0 - np.cos(theta)  # noqa: E731
    assert _left_of("gravity", gravity, command) < 0.3
    both_ways = response_deg(MODEL, command - 30.0, RATE_HZ)
    assert both_ways.min() < -25.0 and both_ways.max() > 25.0
    assert _left_of("gravity", gravity, command - 30.0) > 0.5  # its mean is an offset
    # a spring's own θ³ against gravity's form, the same both ways
    cubic = lambda theta: theta**3  # noqa: E731
    assert _left_of("cubic_stiffness", cubic, command) < 0.3
    assert _left_of("cubic_stiffness", cubic, command - 30.0) > 0.8


def test_a_concealed_load_on_a_finger_bent_one_way_is_not_scored_as_gravity() -> None:
    """A ramp bends the stiff finger 0 to 60°: its concealed gravity (mounted at −11°) is
    0.74 × the noise above the plain refit, but a cubic spring takes all but 0.15 of it; at
    the evident size 0.75 is left, and the case is scored."""
    concealed = cs.build(cs.CaseSpec("gravity", "ramp", 2, "concealed", "stiff", 100.0, 0.3906944025265979))
    assert 0.4 <= concealed.visibility <= 1.5
    assert not concealed.observable
    assert concealed.reason.startswith("indistinct from cubic_stiffness"), concealed.reason
    evident = cs.build(cs.CaseSpec("gravity", "ramp", 2, "evident", "stiff", 100.0, 2.2611203138856992))
    assert evident.observable, evident.reason


def test_a_constant_torque_is_the_sensor_offset_and_a_swing_is_not() -> None:
    """Dry friction on a finger that moves one way (a slow release) shifts the angle by a
    near constant, which the sensor's offset and drift take; a residual that swings with
    the finger is left whole."""
    command = np.zeros(3000)
    released = response_deg(MODEL, command, RATE_HZ, 40.0)
    shifted = 0.3 * (1.0 - released / 40.0)  # what a friction torque does on a first-order finger
    noise = 0.1
    truth = released + shifted
    _, left = distinct_visibility("coulomb_friction", truth, command, RATE_HZ, MODEL, 40.0, noise)
    assert left < 0.4 * np.sqrt(np.mean(shifted**2)) / noise
    swing = 0.3 * np.sin(2 * np.pi * 1.5 * np.arange(3000) / RATE_HZ)
    _, left = distinct_visibility("coulomb_friction", released + swing, command, RATE_HZ, MODEL, 40.0, noise)
    assert left == pytest.approx(np.sqrt(np.mean(swing**2)) / noise, rel=0.05)


def test_a_slow_valve_that_a_free_refit_would_absorb_is_left_visible() -> None:
    """k, B and N held within a lab's ±25 %: a valve lag on an over-damped finger, which a
    free refit mimics by scaling all three, is not absorbed."""
    overdamped = LinearModel(1e-5, 0.05, 0.5, 0.01)
    t = np.arange(3000) / RATE_HZ
    command = np.where((t % 6.0) < 3.0, 60.0, 10.0)
    plain_deg = response_deg(overdamped, command, RATE_HZ)
    lagged = response_deg(LinearModel(1e-5, 0.05, 0.5, 0.01, valve_tau_s=0.03), command, RATE_HZ)
    noise = float(np.sqrt(np.mean((lagged - plain_deg) ** 2)))  # the lag is 1 × the noise
    _, left = distinct_visibility("valve_lag", lagged, command, RATE_HZ, overdamped, 0.0, noise)
    assert left > 0.4


def test_a_drags_linear_part_is_the_nominals_damping_not_the_drags_visibility() -> None:
    """The truth's air drag has a linear part, c2·1 rad/s, which on an over-damped finger
    (where a drag must be large to show at its low speeds) is seven times B. A lab measures
    it with B: the case's nominal holds it (within the battery's ±10 %), and the judge's
    plain finger too, so that what is judged is the drag's quadratic part. Let go from 30°,
    the finger stays under 1 rad/s, and that part is not told from k, B and N; the same drag
    on the ringing finger's steps is."""
    c2 = 0.3564271371141283
    release = cs.build(cs.CaseSpec("quadratic_damping", "free_release", 1, "evident", "overdamped", 200.0,
                                   c2))
    family = cs.FAMILIES["overdamped"]
    assert release.nominal.damping_nms_per_rad == pytest.approx(family.damping_nms_per_rad + c2, rel=0.1)
    assert not release.observable
    assert release.reason.startswith("absorbed by k, B, N and the sensor's offset"), release.reason
    steps = cs.build(cs.CaseSpec("quadratic_damping", "steps", 2, "evident", "ringing", 500.0,
                                 0.0019496641538613254))
    assert steps.observable, steps.reason


def test_the_eight_state_torques_take_a_pressure_stiffening_a_contact_leaves_more() -> None:
    """on_request's measured observability (distinct.left_over with library_torques): on a
    slow sine bending the finger 0 to 60°, a pressure stiffening's extra k·c·p·θ is nearly a
    function of θ (the pressure follows the angle), so the eight's state torques take all but
    a little of what k, B and N leave; a stop met past 45° (one-sided, (θ − θc)^1.5) keeps
    more of it."""
    t = np.arange(3000) / RATE_HZ
    command = 30.0 + 29.0 * np.sin(2 * np.pi * 0.1 * t)
    plain_deg = response_deg(MODEL, command, RATE_HZ)
    theta = plain_deg * DEG
    omega = np.gradient(theta) * RATE_HZ
    stiffening = -0.01 * MODEL.stiffness_nm_per_rad * (command / 60.0) * theta
    contact = -0.05 * np.clip(theta - 45.0 * DEG, 0.0, None) ** 1.5
    left = {}
    for name, torque in (("pressure_stiffening", stiffening), ("contact", contact)):
        effect_deg = torque_response_rad(MODEL, torque, RATE_HZ) / DEG
        plain = plain_sensitivities(MODEL, command, RATE_HZ, 0.0)
        alone = effect_deg - plain @ np.linalg.lstsq(plain, effect_deg, rcond=None)[0]
        noise = float(np.sqrt(np.mean(alone**2)))  # k, B and N leave 1 × the noise of it
        left[name] = left_over(plain_deg + effect_deg, command, RATE_HZ, MODEL, 0.0, noise,
                               library_torques(plain_deg, omega))
        # k, B and N held by the lab's ±25 %, the offset and drift free: most of it is left
        assert left_over(plain_deg + effect_deg, command, RATE_HZ, MODEL, 0.0, noise, []) > 0.5
    assert left["pressure_stiffening"] < 0.05
    assert left["contact"] > 2.0 * left["pressure_stiffening"]
