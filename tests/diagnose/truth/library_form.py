"""The library's forms fitted to the truth's, apart from diagnose's search (best_form): for
pressure stiffening, the library's k·(1 + c·p/p_ref) against the truth's power or
exponential; for contact (contact_form) the library's contact against Hunt-Crossley's:
what a contact max(K·(θ − θc)^n + C·θ', 0) (docs/formats.md §2.1: a Kelvin-Voigt damper)
at its best leaves of the truth's Hunt-Crossley contact, K·δ^1.5·(1 + λ·δ'), whose damper
grows with the depth, and where that best form puts the contact.

The fit is the library's own model (the project's simulator) fitted by output error to the
truth's noise-free angle on the recorded command (the sensor's offset and slow drift taken
out as diagnose takes them): k, B, N, K, θc, n and C together, from
the truth's onset, Hertz's n = 1.5 and no damper and from starts beside them, the best
kept. `left` (its RMS error over the sensor's noise RMS) says whether the library's form
can explain the contact (below observability.OBSERVABLE_LEFT) or only part of it (then
diagnose's "partial" is the truthful answer), and beside `plain_left` (k, B and N alone)
how much of the contact the library's form can show at all (`gain`, observability.observable);
its spring's torque at the deepest angle recorded is the size an estimate is scored against
(its K alone, at another n, is not comparable). `eight_fit` fits the eight's effects of the
finger's state in the same way, for any effect beyond them: what none of them can draw
(`left_of` it)."""

from __future__ import annotations

import dataclasses
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tests.diagnose.truth import cases as cs

DEG = math.pi / 180.0
# the fit's starts: (θc − the truth's onset in degrees, n); the damper's from 0
STARTS = ((0.0, 1.5), (-5.0, 2.0), (3.0, 1.2))
# the eight's effects whose torques are functions of the finger's state (in the library's
# forms what distinct.library_torques linearises), and the sizes the two that draw a
# posture-dependent torque are fitted from alone, neutral first (N·m/rad³ and N·m)
EIGHT_STATE = ("cubic_stiffness", "gravity", "coulomb_friction", "quadratic_damping", "asymmetric_stiffness")
STATE_STARTS = {"cubic_stiffness": (0.0, 0.5, -0.5), "gravity": (0.0, 0.05, -0.05)}


@dataclass(frozen=True)
class ContactForm:
    stiffness_nm_per_radn: float
    onset_deg: float
    exponent: float
    damping_nms_per_rad: float
    left: float  # what the best library form leaves over the noise RMS
    plain_left: float  # what k, B and N alone leave, for comparison
    # the best fit itself (its parameters and angle), for the recording's test (recorded.py)
    fit: Any = dataclasses.field(default=None, compare=False, repr=False)

    @property
    def gain(self) -> float:
        """The part of the angle the form explains beyond k, B and N, over the noise RMS."""
        return math.sqrt(max(self.plain_left**2 - self.left**2, 0.0))

    def torque_nm(self, theta_deg: float) -> float:
        return contact_torque_nm(self.stiffness_nm_per_radn, self.onset_deg, self.exponent, theta_deg)


def contact_torque_nm(stiffness_nm_per_radn: float, onset_deg: float, exponent: float,
                      theta_deg: float) -> float:
    """The library's contact torque at θ."""
    return stiffness_nm_per_radn * (max(theta_deg - onset_deg, 0.0) * DEG) ** exponent


def case_model(case: cs.Case):
    """The case's nominal model, as its files give it to diagnose."""
    from hand_service.config.profile import load_model

    with tempfile.TemporaryDirectory(prefix="library-form-") as scratch:
        _, path = cs.write(case, Path(scratch))
        return load_model(path)


def _fitted_plain(case: cs.Case, held: bool = False):
    """The truth's noise-free angle as diagnose fits it (the sensor's offset and slow drift as
    nuisances): (the problem, k, B and N's parameters, their fit alone, the effects' scales).
    `held`: k, B and N held by a lab's knowledge of them, diagnose's log-normal prior of
    PRIOR_RELATIVE_WIDTH about the truth's plain finger weighted by the sensor's noise RMS
    (as observability.library_left holds them): free, an over-damped finger's k, B and N
    slide together along what the recording pins (their ratios), and an effect's bounds,
    absolute, widen with them."""
    from hand_service.diagnose.fitting.output_error import fit
    from hand_service.diagnose.model.params import EffectScales, Param
    from hand_service.diagnose.model.problem import PLAIN, PRIOR_RELATIVE_WIDTH, Prior, build_problem
    from hand_service.diagnose.residual.noise import nuisance_only

    model = case_model(case)
    traj, rate = case.trajectory, case.rate_hz
    t_s = np.arange(traj.theta_deg.size) / rate
    problem = dataclasses.replace(build_problem(model, t_s, traj.command_kpa, traj.theta_deg, rate),
                                  noise=nuisance_only(traj.theta_deg.size, rate))
    family = case.truth.family
    plain = [Param.plain(name, getattr(model, name)) for name in PLAIN]
    plain_start = [family.stiffness_nm_per_rad, family.damping_nms_per_rad + cs.linear_damping(case.truth),
                   family.gain_nm_per_kpa]
    if held:
        problem.prior = Prior({p.label: v for p, v in zip(plain, plain_start, strict=True)},
                              {p.label: PRIOR_RELATIVE_WIDTH for p in plain}, case.sensor.noise_rms_deg)
    alone = fit(problem, plain, plain_start, max_nfev=100)
    scales = EffectScales.of(family.stiffness_nm_per_rad, family.gain_nm_per_kpa, traj.command_kpa,
                             traj.theta_deg, rate)
    return problem, plain, alone, scales


def form_params(effect: str, plain: list, scales) -> tuple[list, list[str]]:
    """k, B and N, the library's `effect` (its size) and its shape parameters diagnose fits:
    (the parameters, the shape's members)."""
    from hand_service.config import effects as fx
    from hand_service.diagnose.model.params import Param

    members = [q.name for q in fx.BY_NAME[effect].shape_parameters]
    return [*plain, Param.effect(effect, scales), *(Param.shape(effect, m) for m in members)], members


def left_of(case: cs.Case, fitted) -> float:
    """What a fit to the noise-free angle leaves of it, over the sensor's noise RMS."""
    return math.sqrt(fitted.rss_deg2 / fitted.n_fit) / case.sensor.noise_rms_deg


def best_form(case: cs.Case, effect: str, size: float,
              shapes: list[dict[str, float]]) -> tuple[dict[str, float], float, float]:
    """The library's `effect` fitted by output error to the truth's noise-free angle with k,
    B and N, its size from `size` and its shape parameters (those diagnose fits) from each
    of `shapes`, the best kept: (its parameters, what it leaves over the noise RMS, what k,
    B and N alone leave)."""
    values, left, plain_left, _ = _best_form_fit(case, effect, size, shapes)
    return values, left, plain_left


def _best_form_fit(case: cs.Case, effect: str, size: float, shapes: list[dict[str, float]]):
    """best_form's figures and its best fit."""
    from hand_service.config import effects as fx
    from hand_service.diagnose.fitting.output_error import fit

    problem, plain, alone, scales = _fitted_plain(case)
    params, members = form_params(effect, plain, scales)
    fits = [fit(problem, params, [*alone.values, size, *(shape[m] for m in members)], max_nfev=100)
            for shape in shapes]
    best = min(fits, key=lambda f: f.rss_deg2)
    values = {fx.BY_NAME[effect].param: best.value(effect), **{m: best.value(effect, m) for m in members}}
    return values, left_of(case, best), left_of(case, alone), best


def eight_fit(case: cs.Case):
    """The truth's noise-free angle fitted by output error with the library's model: k, B and
    N (held as library_left holds them: _fitted_plain's `held`) and the eight's effects of the
    finger's state together (EIGHT_STATE, in their fit ranges); what it leaves (`left_of`) is
    observability.library_left's question without its linearisation. Fitted
    from every effect at neutral, from the cubic spring's and gravity's best alone (each from
    STATE_STARTS) and from both."""
    from hand_service.config import effects as fx
    from hand_service.diagnose.fitting.output_error import fit
    from hand_service.diagnose.model.params import Param

    problem, plain, alone, scales = _fitted_plain(case, held=True)
    neutral = {name: fx.BY_NAME[name].neutral for name in EIGHT_STATE}
    alone_best = {}
    for name, sizes in STATE_STARTS.items():
        params = [*plain, Param.effect(name, scales)]
        fits = [fit(problem, params, [*alone.values, size], max_nfev=100) for size in sizes]
        alone_best[name] = float(min(fits, key=lambda f: f.rss_deg2).value(name))
    starts = [neutral, {**neutral, "cubic_stiffness": alone_best["cubic_stiffness"]},
              {**neutral, "gravity": alone_best["gravity"]}, {**neutral, **alone_best}]
    params = [*plain, *(Param.effect(name, scales) for name in EIGHT_STATE)]
    fits = [fit(problem, params, [*alone.values, *(start[name] for name in EIGHT_STATE)], max_nfev=100)
            for start in starts]
    return min(fits, key=lambda f: f.rss_deg2)


def contact_form(case: cs.Case) -> ContactForm:
    """The library's contact at its best against the truth's contact case (see the module)."""
    onset = case.truth.contact_deg
    values, left, plain_left, best = _best_form_fit(
        case, "contact", case.truth.contact_nm_per_rad15,
        [{"onset_deg": onset + d, "exponent": n, "damping_nms_per_rad": 0.0} for d, n in STARTS])
    return ContactForm(values["stiffness_nm_per_radn"], values["onset_deg"], values["exponent"],
                       values["damping_nms_per_rad"], left, plain_left, best)
