"""A contact is judged determined on what the recording fixes, its spring's torque at the
deepest angle reached (its K trades with n, whose units it takes), with the delta method's
standard error from the fit's covariance; the other effects on their size, as before."""

from __future__ import annotations

import math

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.search import effect_size
from hand_service.diagnose.search.forward_selection import DETERMINED_Z, Candidate
from rtcore import Prbm
from rtcore.sim import SimFinger

FINGER = SimFinger(prbm=Prbm(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
                             pressure_gain_nm_per_kpa=0.0119, lever_arm_m=0.0))
CONTACT = [Param.effect("contact"), *(Param.shape("contact", m) for m in
                                      ("onset_deg", "exponent", "damping_nms_per_rad"))]
VALUES = np.array([20.0, 40.0, 1.5, 0.05])  # K N·m/radⁿ, θc deg, n, C N·m·s/rad
DEEPEST_DEG = 70.0


def torque_gradient(values: np.ndarray, deepest_deg: float) -> np.ndarray:
    """d(K·δⁿ)/d(K, θc, n, C), δ = θmax − θc in radians, by hand."""
    k, onset, n, _ = values
    depth = math.radians(deepest_deg - onset)
    return np.array([depth**n, -k * n * depth ** (n - 1.0) * math.pi / 180.0,
                     k * depth**n * math.log(depth), 0.0])


def contact_fit(jacobian: np.ndarray, values: np.ndarray = VALUES) -> Fit:
    samples = jacobian.shape[0]
    angle = np.linspace(0.0, DEEPEST_DEG, samples)  # the fitted finger's deepest angle
    return Fit(tuple(CONTACT), values.copy(), FINGER, angle, 0.01 * samples, jacobian, samples)


def traded_jacobian(seed: int = 1) -> np.ndarray:
    """The angle sees K, θc and n almost only through the spring's torque (they trade), and
    the damper on its own."""
    rng = np.random.default_rng(seed)
    samples = 400
    along = rng.normal(size=samples)
    jacobian = np.outer(along, torque_gradient(VALUES, DEEPEST_DEG)) * 50.0
    jacobian[:, :3] += 1e-4 * rng.normal(size=(samples, 3))
    jacobian[:, 3] = rng.normal(size=samples)
    return jacobian


def test_the_contact_derived_size_is_its_spring_torque_at_the_deepest_angle() -> None:
    spec = fx.BY_NAME["contact"]
    values = {"stiffness_nm_per_radn": 20.0, "onset_deg": 40.0, "exponent": 1.5, "damping_nms_per_rad": 0.05}
    size = spec.derived_size(values, DEEPEST_DEG)
    assert size is not None and size.unit == "N·m"
    assert math.isclose(size.value, 20.0 * math.radians(30.0) ** 1.5)
    shallow = spec.derived_size(values, 30.0)  # never past the onset: no spring torque
    assert shallow is not None and shallow.value == 0.0
    assert spec.refining == ("damping_nms_per_rad",)


def test_the_other_effects_keep_their_size() -> None:
    for name in ("cubic_stiffness", "valve_lag", "coulomb_friction", "hysteresis", "creep"):
        spec = fx.BY_NAME[name]
        assert spec.derived_size(spec.full({}), DEEPEST_DEG) is None
        assert spec.refining == ()


def test_the_torque_std_is_the_delta_method_on_the_fit_covariance() -> None:
    fit = contact_fit(np.random.default_rng(3).normal(size=(300, 4)))
    size = effect_size.derived_size(fit, "contact")
    assert size is not None
    gradient = torque_gradient(VALUES, DEEPEST_DEG)
    expected = math.sqrt(gradient @ fit.covariance() @ gradient)
    assert math.isclose(size.std, expected, rel_tol=1e-4)
    assert math.isclose(size.value, 20.0 * math.radians(DEEPEST_DEG - 40.0) ** 1.5)


def test_a_contact_whose_k_trades_with_n_is_determined_by_its_torque() -> None:
    fit = contact_fit(traded_jacobian())
    k_std = float(fit.std()[0])
    assert VALUES[0] < DETERMINED_Z * k_std  # K alone would not be determined
    size = effect_size.derived_size(fit, "contact")
    assert size is not None and size.value > 10.0 * DETERMINED_Z * size.std
    candidate = Candidate("contact", CONTACT[0], 0.5, 0.5, 1.0, fit, 400.0, 7.7, 0.1)
    assert candidate.determined


def test_a_contact_with_no_spring_torque_is_not_determined() -> None:
    values = VALUES.copy()
    values[1] = DEEPEST_DEG + 5.0  # the onset beyond the deepest angle: the damper alone acts
    fit = contact_fit(np.random.default_rng(3).normal(size=(300, 4)), values)
    assert not Candidate("contact", CONTACT[0], 0.5, 0.5, 1.0, fit, 400.0, 7.7, 0.1).determined


def test_without_refining_drops_only_the_contact_damper() -> None:
    fit = contact_fit(np.random.default_rng(3).normal(size=(300, 4)))
    core = effect_size.without_refining(fit, "contact")
    assert core is not None
    params, values = core
    assert [p.member for p in params] == ["", "onset_deg", "exponent"]
    assert values == [20.0, 40.0, 1.5]


def damper_traded_jacobian(seed: int = 1) -> np.ndarray:
    """The angle sees the spring's torque and the damper almost only together: in the joint
    fit the spring's torque is not pinned (the damper takes any share of it)."""
    rng = np.random.default_rng(seed)
    samples = 400
    along = rng.normal(size=samples)
    jacobian = np.outer(along, torque_gradient(VALUES, DEEPEST_DEG))
    jacobian[:, 3] = 1e3 * along * (1.0 + 1e-4 * rng.normal(size=samples))
    jacobian[:, :3] += 1e-5 * rng.normal(size=(samples, 3))
    return jacobian


def test_a_contact_whose_spring_trades_with_its_damper_is_judged_on_the_spring_alone() -> None:
    """Where the joint fit cannot split the torque between spring and damper, the contact is
    determined only if its spring, refitted alone, both beats the plain model (carries) and
    stands clear of 0 there (core_determined)."""
    fit = contact_fit(damper_traded_jacobian())
    size = effect_size.derived_size(fit, "contact")
    assert size is not None and size.value < DETERMINED_Z * size.std  # not pinned in the joint fit

    def candidate(carries: bool, core_determined: bool) -> Candidate:
        spread = abs(size.value) / (2 * DETERMINED_Z if core_determined else 1)  # clear of 0, or not
        core = effect_size.SizeEstimate(size.value, spread, size.unit, size.what)
        return Candidate("contact", CONTACT[0], 0.5, 0.5, 1.0, fit, 400.0, 7.7, 0.1, 0.0, carries, core)

    assert not candidate(True, False).determined
    assert not candidate(False, True).determined  # a spring that does not carry is no evidence
    assert candidate(True, True).determined


def test_the_contact_core_start_keeps_the_spring_torque_at_hertz_exponent() -> None:
    spec = fx.BY_NAME["contact"]
    values = {"stiffness_nm_per_radn": 0.16, "onset_deg": 75.7, "exponent": 2.35, "damping_nms_per_rad": 0.0}
    (start,) = spec.core_starts(values, 99.5)
    assert start["exponent"] == 1.5 and start["onset_deg"] == 75.7
    before, after = spec.derived_size(values, 99.5), spec.derived_size(start, 99.5)
    assert before is not None and after is not None and math.isclose(after.value, before.value)
    assert spec.core_starts({**values, "exponent": 1.5}, 99.5) == []  # already there
    assert spec.core_starts({**values, "onset_deg": 100.0}, 99.5) == []  # no spring torque to keep
    assert fx.BY_NAME["cubic_stiffness"].core_starts(fx.BY_NAME["cubic_stiffness"].full({}), 99.5) == []
