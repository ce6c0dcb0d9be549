"""Naming the missing physics: every library effect fitted jointly with the plain model.

Round by round (forward selection), each effect not yet in the model is fitted together
with k, B, N (A held) and the effects already accepted. An effect is accepted when

- the information criterion favours it strongly (ΔBIC > SIGNIFICANT_BIC), and
- it predicts the held-out data better by more than the noise allows (z > SIGNIFICANT_Z),
- and no other effect explains the same residual nearly as well (`tied`): then neither is
  named, but the better is carried in the model, unnamed, and the next rounds look for
  what else is missing (a lag/dead-time tie must not drop a clear second effect).

Each fit starts from the Gauss-Newton step of the effect's signature (the angle's
sensitivity to its parameter, what k, B and N absorb projected out); its correlation with
the residual is the score (Lagrange multiplier) test, reported as the signature correlation.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit, far_from_nominal, fit, nominal_prior, unpinned
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import stats
from hand_service.diagnose.search import effect_size
from hand_service.diagnose.search.admission import admitted, beside_a_tie, friction_rival, kept
from hand_service.diagnose.search.held_out import expected_z, second_split_z
from hand_service.diagnose.search.joint_start import joint_range, nominal_start
from hand_service.diagnose.search.prior_evidence import prior_chi2
from hand_service.diagnose.search.screening import WHOLE_GRID, Screen, screen, start_value
from hand_service.diagnose.workers import ordered_map

SIGNIFICANT_BIC = 10.0  # "very strong" on Kass and Raftery's scale
SIGNIFICANT_Z = 2.0  # one-sided 2 % for a change that only fits noise (whose z is biased low)
BORDERLINE_Z = 1.0  # between this and SIGNIFICANT_Z, a second held-out quarter is asked too
LOOK_AGAIN_Z = -1.0  # and for a round's best, between this and BORDERLINE_Z (second_look)
SHORTFALL_Z = 3.0  # when that z falls this far below what the best's gain in the fit predicts
NAME_MARGIN_BIC = 10.0
MAX_EFFECTS = 3
THOROUGH_TOP = 3  # the screen's best three are fitted from every start, the rest from one
LATER_TOP = 3  # after the first round, only the screen's best three are fitted
LATER_WHITE_BIC = 0.0  # and of those only what the screen predicts above this on the innovations
DETERMINED_Z = 3.0  # an effect's estimate must stand this many standard errors from neutral
PRIOR_EVIDENCE_FACTOR = 10.0  # a refit this many times off the nominal makes its prior evidence

Progress = Callable[[str], None]


def clear_of_zero(size: effect_size.SizeEstimate | None) -> bool:
    """A derived size stands DETERMINED_Z of its standard errors clear of 0."""
    return size is not None and bool(abs(size.value) > DETERMINED_Z * size.std)


@dataclass
class Candidate:
    name: str
    param: Param
    signature_corr: float  # corr(residual, signature after projecting out the model's own parameters)
    separability: float  # share of the signature the model's own parameters cannot absorb
    start: float
    fit: Fit
    delta_bic: float  # against the model of this round, the nominal's prior included
    z_heldout: float
    rmse_heldout_deg: float  # held out, the sensor's offset and drift taken out (Problem.misfit)
    prior_gain: float = 0.0  # how much closer to the nominal (prior's χ²) the effect lets k, B, N stay
    carries: bool = True  # it beats `base` with its refining parameters at neutral too (effect_size.py)
    core_size: effect_size.SizeEstimate | None = None  # its derived size, so refitted

    @property
    def index(self) -> int:
        """Where the effect's size is among the fit's parameters (its shape follows it)."""
        return next(i for i, p in enumerate(self.fit.params) if p.label == self.name and p.is_size)

    @property
    def estimate(self) -> float:
        return float(self.fit.values[self.index])

    @property
    def std(self) -> float:
        return float(self.fit.std()[self.index])

    @property
    def at_bound(self) -> bool:
        """Pinned at a plausible bound other than neutral: the effect is being stretched to
        mimic something else, so it is not evidence for itself."""
        return self.at_bound_in(self.fit)

    def at_bound_in(self, joint: Fit) -> bool:
        """Its size pinned so in `joint`, a fit that holds it (a set's final fit, say)."""
        p = self.param
        span = p.upper - p.lower
        neutral = fx.BY_NAME[self.name].neutral
        estimate = joint.value(p.label, p.member)
        return any(abs(estimate - b) < 1e-6 * span and b != neutral for b in (p.lower, p.upper))

    @property
    def core_determined(self) -> bool:
        """The derived size refitted without the refining parameters stands DETERMINED_Z clear."""
        return clear_of_zero(self.core_size)

    @property
    def determined(self) -> bool:
        """The estimate stands clear of "no effect" by DETERMINED_Z of its own standard
        errors in the joint fit (with k, B, N free and their prior): what the recording
        cannot tell from k, B or N shows as a large std. (A correlation with k, B or N
        alone is no measure: on an over-damped finger k, B and N move together, and an
        effect known to 3 % correlates at 0.997 with their common scale.) An effect whose
        size trades with its shape is judged on what the recording fixes instead (a
        contact's spring torque at the deepest angle: effect_size.derived_size), in the joint
        fit or, where the effect carries itself without its refining parameters, in that
        refit (carries_itself): a damper beside the spring widens the spring's error in the
        joint fit as it takes a share of the torque, while the spring alone is pinned."""
        derived = effect_size.derived_size(self.fit, self.name)
        if derived is not None:
            return clear_of_zero(derived) or (self.carries and self.core_determined)
        neutral = fx.BY_NAME[self.name].neutral
        return bool(abs(self.estimate - neutral) > DETERMINED_Z * self.std)

    @property
    def predicts(self) -> bool:
        """The held-out data favour it; or, where the plain refit went beyond the nominal's
        stated uncertainty, it brings k, B and N back (the prior's χ² drops by SIGNIFICANT_BIC)
        without predicting worse: a slow valve the refit mimicked by scaling k, B and N."""
        return self.z_heldout > SIGNIFICANT_Z or (self.prior_gain > SIGNIFICANT_BIC and self.z_heldout > -1.0)

    @property
    def significant(self) -> bool:
        return (self.delta_bic > SIGNIFICANT_BIC and self.predicts and not self.at_bound and self.determined
                and self.carries)


@dataclass
class Round:
    base: Fit  # the model this round starts from
    candidates: list[Candidate]  # strongest first
    uncarried: list[Candidate] = field(default_factory=list)  # fitted, not carrying itself (late_stand_in)

    def best(self) -> Candidate | None:
        return self.candidates[0] if self.candidates else None


@dataclass
class Selection:
    rounds: list[Round] = field(default_factory=list)
    accepted: list[Candidate] = field(default_factory=list)
    final: Fit | None = None
    ambiguous: tuple[Candidate, Candidate] | None = None
    carried: list[Candidate] = field(default_factory=list)  # in the model, unnamed: one of a tie


def evidence(problem: Problem, base: Fit, before: np.ndarray, joint: Fit) -> tuple[float, float, np.ndarray]:
    """The joint fit's ΔBIC over `base` (whose innovations are `before`) on the innovations,
    the share of it that is the nominal's prior (counted only where the data asked for a
    refit an order of magnitude from it: 9 widths of its log-normal prior, a χ² of 85;
    nearer, the prior holds k, B and N but decides nothing: hysteresis on a ramp pulled B 4×
    off, and a valve lag pulled it back), and the joint fit's innovations. A joint fit whose
    finger diverges (its angle not finite: an output-error fit takes that as a very bad
    fit, error_rows) gains −∞, and `base`'s innovations stand for its own."""
    if not np.all(np.isfinite(joint.angle_deg)):
        return -np.inf, 0.0, before  # the fit drove the finger unstable: it explains nothing
    far = bool(far_from_nominal(problem, base, PRIOR_EVIDENCE_FACTOR))
    prior_gain = prior_chi2(problem, base) - prior_chi2(problem, joint) if far else 0.0
    after = problem.innovations(joint.angle_deg)
    # the effect's size and its shape parameters (an onset, a travel) each pay the penalty
    extra = len(joint.params) - len(base.params)
    bic = stats.delta_bic(problem.fit_rss(before), problem.fit_rss(after), problem.n_fit, extra) + prior_gain
    return bic, prior_gain, after


def score(problem: Problem, base: Fit, screened: Screen, sigma: float, thorough: bool = True,
          lazy: bool = False) -> Candidate:
    """Fit the screened effect jointly with every parameter of `base`, from each start
    (`thorough`), or from the most promising one only (an effect the screen gives no chance,
    fitted for the evidence table alone). `lazy` (the later rounds, where every simulation
    carries the effects accepted so far, dry friction's ten times dearer): from the most
    promising start first, and from the others only if that fit gains (ΔBIC above 0). Not
    the screen's prediction: taken on the raw residual, which correlated noise inflates."""
    shape, shaped = problem.shape_of(screened.name)  # fitted beside its size
    params = (*joint_range(problem, base), screened.param, *shape)
    starts = [[*base.values, s, *shaped] for s in screened.starts]
    reset = nominal_start(problem, base)
    if reset is not None:
        starts.append([*reset, screened.starts[-1], *shaped])
    promising = starts[-1:] if len(screened.starts) > 1 else starts[:1]  # the scan's best point

    def fit_from(starts: list[list[float]], problem: Problem) -> Fit:
        fits = ordered_map(lambda start: fit(problem, params, start, base=base.finger), starts)  # each a fit
        return min(fits, key=lambda f: f.cost_deg2)  # what the fit minimised: the data and the prior

    if not thorough:
        starts = promising
    before = problem.innovations(base.angle_deg)
    if lazy and thorough and len(starts) > 1:
        joint = fit_from(promising, problem)
        if evidence(problem, base, before, joint)[0] <= 0.0:
            starts = promising
        else:
            joint = min(joint, fit_from([s for s in starts if s is not promising[0]], problem),
                        key=lambda f: f.cost_deg2)
    else:
        joint = fit_from(starts, problem)
    if joint.cost_deg2 > base.cost_deg2:  # every start ended worse than no effect at all: from there
        neutral = start_value(screened.param, fx.BY_NAME[screened.name].neutral, 0.0)
        joint = min(joint, fit(problem, params, [*base.values, neutral, *shaped], base=base.finger),
                    key=lambda f: f.cost_deg2)
    if problem.prior.weight_deg == 0.0 and unpinned(joint):
        # The plain refit was pinned by the data, but with the effect beside it k, B and N
        # slide together (a slow sine below resonance fixes only their ratios, and a gravity
        # load made a ringing finger's k, B, N and G 40 times the nominal at equal cost): the
        # nominal's uncertainty holds them, as it holds a refit the data cannot pin.
        problem = dataclasses.replace(problem, prior=nominal_prior(problem, base.params, base.sigma_deg))
        joint = min((fit(problem, params, start, base=base.finger) for start in starts),
                    key=lambda f: f.cost_deg2)
    held = problem.held_mask
    bic, prior_gain, after = evidence(problem, base, before, joint)
    z = stats.heldout_z_innovations(before[held], after[held], sigma)
    if bic > SIGNIFICANT_BIC and BORDERLINE_Z < z <= SIGNIFICANT_Z:
        z = (z + second_split_z(problem, base, joint)) / np.sqrt(2.0)
    core = carries_itself(problem, base, joint, screened.name, sigma) if bic > SIGNIFICANT_BIC else None
    return Candidate(screened.name, screened.param, screened.signature_corr, screened.separability,
                     screened.starts[0], joint, bic, z, stats.rmse(problem.misfit(joint.angle_deg)[held]),
                     prior_gain, core is None or core.carries, None if core is None else core.size)


@dataclass(frozen=True)
class Core:
    """An effect refitted without its refining parameters (carries_itself)."""

    carries: bool  # it beats the model without it (ΔBIC and the held-out data)
    size: effect_size.SizeEstimate | None = None  # its derived size, so refitted


def carries_itself(problem: Problem, base: Fit, joint: Fit, name: str, sigma: float) -> Core:
    """Effect `name` without its refining parameters (Effect.refining, held at neutral),
    refitted from `joint` and from the effect's other starts (Effect.core_starts), the one
    with the most evidence kept, still beats `base` as an effect must (ΔBIC and the held-out
    data, Candidate.predicts): a contact whose spring carries little of its torque, its
    damper doing the work, is not a contact (a damping that grows with the pressure was
    named so). The refit's local minimum must not decide it: from the joint's shape alone a
    ringing finger's spring slid its onset past the deepest angle (docs/results.md)."""
    core = effect_size.without_refining(joint, name)
    if core is None:
        return Core(True)
    spec = fx.BY_NAME[name]
    refining = [Param.shape(name, member) for member in spec.refining]
    held = problem.finger(refining, [spec.parameter(member).neutral for member in spec.refining], base.finger)
    params, start = core
    where = {p.member or spec.param: i for i, p in enumerate(params) if p.label == name}
    starts = [start]
    for other in spec.core_starts(spec.full({m: start[i] for m, i in where.items()}),
                                  effect_size.deepest_deg(joint)):
        starts.append(list(start))
        for member, i in where.items():
            starts[-1][i] = other[member]
    before = problem.innovations(base.angle_deg)
    best = max(((evidence(problem, base, before, alone), alone)
                for alone in (fit(problem, params, s, base=held) for s in starts)), key=lambda e: e[0][0])
    (bic, prior_gain, after), alone = best
    z = stats.heldout_z_innovations(before[problem.held_mask], after[problem.held_mask], sigma)
    carries = bool(bic > SIGNIFICANT_BIC
                   and (z > SIGNIFICANT_Z or (prior_gain > SIGNIFICANT_BIC and z > -1.0)))
    size = effect_size.derived_size(alone, name)
    return Core(carries, size)


def beside(problem: Problem, base: Fit, name: str, lazy: bool = False) -> Candidate:
    """`name` screened and fitted jointly with every parameter of `base` (the effects before
    it included), scored against `base`'s innovations: a candidate as a round scores it
    (`lazy`: its other starts only where the most promising one gains, see `score`)."""
    sigma = problem.innovation_sigma(problem.innovations(base.angle_deg), len(base.params))
    return score(problem, base, screen(problem, base, name), sigma, lazy=lazy)


def second_look(problem: Problem, round_: Round) -> None:
    """The round's best, strong in the fit (ΔBIC over SIGNIFICANT_BIC) but short of the
    borderline on the held-out quarter, though not worse there by more than the noise
    (LOOK_AGAIN_Z < z ≤ BORDERLINE_Z), and far below what its gain in the fit predicts there
    (by more than SHORTFALL_Z, `expected_z`, where a real effect's z spreads by 1): the
    quarter is not like the rest, and the second quarter is asked too (second_split_z), as
    for a borderline one. An effect whose evidence lies in a few events (dry friction's stops
    at the ends of steps) can find few of them in one quarter: dry friction beside a valve
    lag and a dead zone gained ΔBIC 157 (z 3.7 expected) with a held-out z of 0.4, and 6.9
    on the two quarters. A z nearer its expectation is what a stand-in's gain shrinking out
    of sample looks like, and is left to the one quarter: an asymmetric spring beside a valve
    lag under a hysteresis loop gained ΔBIC 53 (z 2.2 expected) with z 0.3. Only the best is
    asked (it alone can be accepted), and only once."""
    best = round_.best()
    if best is None or best.delta_bic <= SIGNIFICANT_BIC or not LOOK_AGAIN_Z < best.z_heldout <= BORDERLINE_Z:
        return
    if expected_z(problem, round_.base, best) - best.z_heldout <= SHORTFALL_Z:
        return
    z = (best.z_heldout + second_split_z(problem, round_.base, best.fit)) / np.sqrt(2.0)
    round_.candidates[0] = dataclasses.replace(best, z_heldout=z)


def run_round(problem: Problem, base: Fit, names: list[str], progress: Progress | None,
              fit_all: bool, standing: Sequence[str] = ()) -> Round:
    """Screen every effect; fit jointly all of them (`fit_all`, the first round, whose
    table the report shows; the screen's best three from every start, the others from the
    scan's best point) or, in later rounds, the screen's best three, and the effects in
    `standing` whatever the screen says (see `select`). The effects are
    screened and fitted side by side on the machine's cores: each is its own simulations
    (the C simulator runs without the GIL and keeps its state on the stack), and the
    results are taken in the same order whatever finishes first."""
    sigma = problem.innovation_sigma(problem.innovations(base.angle_deg), len(base.params))
    if progress:
        progress(f"screening {', '.join(names)}")
    # the whole-grid scans first: started last, one of them would leave a core idle at the end
    longest_first = sorted(names, key=lambda name: name not in WHOLE_GRID)
    screens = ordered_map(lambda name: screen(problem, base, name), longest_first)
    screens.sort(key=lambda s: (-s.predicted_bic, names.index(s.name)))
    screened = screens
    screens = admitted(problem, screens, NAME_MARGIN_BIC)  # a stand-in only past the screen
    chosen = [s for i, s in enumerate(screens) if fit_all or i < LATER_TOP]
    if not fit_all and not far_from_nominal(problem, base, PRIOR_EVIDENCE_FACTOR):
        # later rounds: an effect whose best point of the scan, k, B, N and the accepted
        # effects readjusted linearly, gains no ΔBIC on the innovations is not fitted (every
        # simulation there carries the accepted effects: dry friction's cost ten times)
        chosen = [s for s in chosen if s.predicted_white_bic > LATER_WHITE_BIC]
    chosen += [s for s in screens if s.name in standing and s not in chosen]
    if progress and chosen:
        progress(f"fitting {', '.join(s.name for s in chosen)} with the model")
    candidates = ordered_map(lambda item: score(problem, base, item[1], sigma, item[0] < THOROUGH_TOP,
                                                lazy=not fit_all),
                             enumerate(chosen))
    candidates.sort(key=lambda c: -c.delta_bic)
    if fit_all:
        let_in = {s.name for s in screens}
        kept_out = [s for s in screened if s.name not in let_in]  # stand-ins the screen kept out
        candidates += beside_a_tie(problem, candidates, kept_out, NAME_MARGIN_BIC,
                                   lambda s: score(problem, base, s, sigma, True))
        candidates.sort(key=lambda c: -c.delta_bic)
    # a stand-in the screen let in that is not significant, or does not beat the eight's fits
    # (and a later round's model so far) on the raw angle, is as if kept out (admission.py)
    return Round(base, kept(problem, base, candidates, later=not fit_all, fit_pair=partial(beside, problem)),
                 [c for c in candidates if not c.carries])


def tied(best: Candidate, runner: Candidate | None, fit_pair: Callable[[Fit, str], Candidate],
         progress: Progress | None = None) -> bool:
    """Two names for one signature: the runner-up significant within the naming margin of the
    best, and the two fitted together (`fit_pair`, `beside`) not clearly better than the best."""
    if runner is None or not runner.significant or best.delta_bic - runner.delta_bic >= NAME_MARGIN_BIC:
        return False
    if progress:
        progress(f"{best.name} or {runner.name}? fitting both together")
    return not fit_pair(best.fit, runner.name).significant


def select(problem: Problem, refit: Fit, names: list[str], progress: Progress | None = None,
           first: Candidate | None = None) -> Selection:
    """Forward selection over `names` from the plain refit (or from `first`, other_first.py)."""
    selection = Selection() if first is None else Selection([Round(refit, [first])], [first])
    current = refit if first is None else first.fit
    remaining = [name for name in names if first is None or name != first.name]
    standing: list[str] = []
    while remaining and len(selection.accepted) < MAX_EFFECTS and len(selection.rounds) <= MAX_EFFECTS:
        round_ = run_round(problem, current, remaining, progress, fit_all=not selection.rounds,
                           standing=standing)
        second_look(problem, round_)
        selection.rounds.append(round_)
        best = round_.best()
        if best is None or not best.significant:
            break
        if len(selection.rounds) > 1:
            # a later round's significant runners-up are fitted again in the next whatever the
            # screen (its linear step misjudges a non-smooth effect beside a new pick); not the
            # first round's: against the plain model, most stand in for the first pick
            standing = [c.name for c in round_.candidates[1:] if c.significant]
        runner = round_.candidates[1] if len(round_.candidates) > 1 else None
        # a loop that dry friction draws as well on the raw angle is a tie with it (admission.py)
        other = friction_rival(problem, best, round_.candidates, remaining, partial(beside, problem, current))
        if other is None and tied(best, runner, partial(beside, problem), progress):
            other = runner
        if other is not None:
            selection.ambiguous = (best, other)
            selection.carried.append(best)
            current = best.fit
            remaining = [name for name in remaining if name not in (best.name, other.name)]
            continue
        selection.accepted.append(best)
        current = best.fit
        remaining.remove(best.name)
    selection.final = current
    return selection
