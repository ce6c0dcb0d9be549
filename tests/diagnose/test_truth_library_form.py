"""The truth's pressure-dependent physics (tests/diagnose/truth/plant.py) and the library's
forms fitted to the truth's (tests/diagnose/truth/library_form.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.library_form import contact_form
from tests.diagnose.truth.plant import DEG, FAMILIES, Truth, simulate

RATE_HZ = 200.0


def test_pressure_damping_is_the_damping_the_pressure_adds() -> None:
    """Under a held pressure p the truth's pressure damping is a finger with B·(1 + r·p/p_fs):
    a step to p rings down as that finger's does, and at twice p it rings down faster."""
    family = FAMILIES["ringing"]
    n, p_kpa, ratio = 400, 40.0, 2.0
    command = np.full(n, p_kpa)
    damped = simulate(Truth(family, pressure_damping_ratio=ratio), RATE_HZ, n, command=command)
    same = dataclasses.replace(family, damping_nms_per_rad=family.damping_nms_per_rad
                               * (1.0 + ratio * p_kpa / family.full_scale_kpa))
    plain = simulate(Truth(same), RATE_HZ, n, command=command)
    assert np.max(np.abs(damped.theta_deg - plain.theta_deg)) < 0.01 * np.ptp(plain.theta_deg)
    undamped = simulate(Truth(family), RATE_HZ, n, command=command)
    assert np.ptp(undamped.theta_deg[100:]) > 3.0 * np.ptp(damped.theta_deg[100:])


@pytest.mark.parametrize("form", ["power", "exp"])
def test_pressure_stiffening_holds_the_finger_where_its_form_says(form: str) -> None:
    """At rest under p, N·p = k·(1 + s·g(p/p_fs))·θ, g = x^0.7 or (e^x − 1)/(e − 1): the
    exponential stiffens less at low pressure and as much at full scale."""
    family = FAMILIES["overdamped"]
    s, n = 1.0, 600
    x = 0.5
    p_kpa = x * family.full_scale_kpa
    rest = simulate(Truth(family, stiffening_s=s, stiffening_form=form), RATE_HZ, n,
                    command=np.full(n, p_kpa)).theta_deg[-1]
    g = math.expm1(x) / (math.e - 1.0) if form == "exp" else x**0.7
    expected = family.gain_nm_per_kpa * p_kpa / (family.stiffness_nm_per_rad * (1.0 + s * g)) / DEG
    assert rest == pytest.approx(expected, rel=1e-3)


def _contact_case(damping_s_per_rad: float) -> cs.Case:
    """The concealed contact on the stiff finger's multisine (seed 0, 200 Hz), its strength
    the calibrated one, with the truth's Hunt-Crossley damping λ as given."""
    case = cs.build(cs.CaseSpec("contact", "multisine", 0, "concealed", "stiff", 200.0, 0.4407502215875222))
    truth = dataclasses.replace(case.truth, contact_damping_s_per_rad=damping_s_per_rad)
    traj = simulate(truth, case.rate_hz, case.plan.n, command=case.trajectory.command_kpa,
                    theta0_deg=case.plan.theta0_deg)
    return dataclasses.replace(case, truth=truth, trajectory=traj)


@pytest.mark.thorough  # about 20 s
def test_the_librarys_contact_explains_an_undamped_contact_and_a_damped_one() -> None:
    """Hunt-Crossley's elastic part is the library's form at n = 1.5 with no damper: fitted
    to it, the library's contact leaves a tenth of the noise or less, with the truth's onset
    and n and no damping. With the truth's damping (λ = 0.3 s/rad, growing with the depth)
    the library's Kelvin-Voigt damper takes its place: the best form, with a damper, leaves
    less than the observability bar (0.4 × the noise)."""
    elastic = contact_form(_contact_case(0.0))
    case = _contact_case(0.0)
    assert elastic.left < 0.1
    assert elastic.onset_deg == pytest.approx(case.truth.contact_deg, abs=1.0)
    assert elastic.exponent == pytest.approx(1.5, abs=0.15)
    assert elastic.damping_nms_per_rad < 1e-6
    damped = contact_form(_contact_case(0.3))
    assert damped.left < 0.4 and damped.damping_nms_per_rad > 0.0
