"""`diagnose` end to end: nominal, refit, locate, name, judge (docs/formats.md contract).

    a. simulate the nominal model on the recorded command, from the recorded state;
    b. refit k, B, N (A and the model's own effects held) by output-error least squares;
    c. locate: residual whiteness, cross-correlation with the past input, windows in time,
       and each library effect's signature correlation;
    d. name: forward selection over the library effects the model leaves out (search/forward_selection.py);
    e. judge: consistent / parameters_only / missing_physics / unexplained /
       insufficient_excitation.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from hand_service.config.model import FingerModel
from hand_service.diagnose import workers
from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import (
    FAR_FACTOR,
    Fit,
    far_from_nominal,
    fit,
    nominal_prior,
    relative_std,
    unpinned,
)
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN, Problem, build_problem
from hand_service.diagnose.model.unit_check import check_nominal
from hand_service.diagnose.outside_library.checks import Outside, outside_checks
from hand_service.diagnose.recording import excitation
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.diagnose.report.found import found_effect
from hand_service.diagnose.report.verdict import (
    SEPARABLE_MIN,
    FoundEffect,
    explained_share,
    judge,
    late_structure,
    plural,
    prior_share,
    structure_left,
    trade_offs,
)
from hand_service.diagnose.requested import contact_at_onset, searched, shape_only
from hand_service.diagnose.residual import noise, noise_only, stats
from hand_service.diagnose.residual.offset_drift import drift_said
from hand_service.diagnose.search import (
    excerpt,
    loop_rival,
    posture_stability,
    rest_order,
    revisions,
    rival_check,
    set_members,
)
from hand_service.diagnose.search.admission import gated
from hand_service.diagnose.search.forward_selection import SIGNIFICANT_BIC, Progress, Selection
from hand_service.diagnose.search.late_stand_in import select_screened
from hand_service.diagnose.search.prior_evidence import data_alone_bic


def plain_params(problem: Problem, model: FingerModel, warnings: list[str]) -> list[Param]:
    params = [Param.plain(name, getattr(model, name)) for name in PLAIN]
    lowest = float(np.min(problem.pressure_kpa))
    if lowest < 0.0:
        warnings.append(f"the command goes down to {lowest:.4g} kPa: taken as a signed input (a vacuum "
                        "or bipolar drive) and simulated as it is, not clamped at 0 kPa")
    if np.ptp(problem.pressure_kpa) == 0.0 and problem.pressure_kpa[0] == 0.0:
        warnings.append("the pressure command is zero throughout: the pressure gain N cannot be "
                        "measured and is held at the model's value")
        params = [p for p in params if p.label != "pressure_gain_nm_per_kpa"]
    return params


NAMING = ("missing_physics", "unexplained")  # verdicts with effects found, named or partial
REPORT_FACTOR = 2.0  # a plain refit this many times off the nominal is said


def refit_with_prior(problem: Problem, params: list[Param], refit: Fit,
                     progress: Progress | None) -> Fit:
    """k, B and N refitted with the nominal's uncertainty as a log-normal prior (width
    PRIOR_RELATIVE_WIDTH, weighted by the plain refit's noise), from the nominal and from
    the plain refit; the one with the lower cost."""
    if progress:
        progress("the recording cannot pin every plain parameter: refitting with the nominal as a prior")
    problem.prior = nominal_prior(problem, params, refit.sigma_deg)
    return min((fit(problem, params, start) for start in (problem.values(params), refit.values)),
               key=lambda f: f.cost_deg2)


def refit_distance(model: FingerModel, refit: Fit) -> str:
    """How far the refit moved k, B and N from the nominal, in words: "with k 0.0031, B 0.0029
    and N 0.0034 times the nominal's"."""
    ratios = [f"{label} {refit.value(name) / getattr(model, name):.2g}"
              for label, name in (("k", "stiffness_nm_per_rad"), ("B", "damping_nms_per_rad"),
                                  ("N", "pressure_gain_nm_per_kpa")) if getattr(model, name)]
    return f"(with {', '.join(ratios)} times the nominal's)" if ratios else ""


def models(nominal_angle_deg: np.ndarray, refit: Fit, final: Fit) -> dict[str, np.ndarray]:
    """The three models' simulated angles, by the names the figures use."""
    return {"nominal": nominal_angle_deg, "refit": refit.angle_deg, "augmented": final.angle_deg}


def diagnose(model: FingerModel, t_s: np.ndarray, pressure_kpa: np.ndarray, angle_deg: np.ndarray,
             rate_hz: float, progress: Progress | None = None,
             missing: np.ndarray | None = None, input_hold: str = "zoh",
             noise_model: str = "ar", also: Sequence[str] = (), jobs: int | None = None) -> Diagnosis:
    """`noise_model`: "ar" (default), the sensor noise correlated in time on a drifting
    offset (residual/noise.py), so that clean recordings from a lab's sensor come out clean; or
    "white", independent samples. `also`: library effects asked for by name, searched beyond
    the default ones, by the same tests, and fitted whatever the screen says. `jobs`: the threads its
    simulations run on (diagnose/workers.py; None: HAND_DIAGNOSE_THREADS or the cores, 1:
    one thread), the same answer bit for bit on any number.

    BLAS runs one thread meanwhile: diagnose's own threads (the effects' and starts' pools, the
    Jacobian's columns in fitting/output_error.py) keep the cores busy, and OpenBLAS, which
    threads every dot product past about 10 000 samples (the residual statistics at 500 Hz
    and 1 kHz), would only make them wait."""
    def run(part: slice, search: list[str], graded: bool) -> Diagnosis:  # see excerpt.Run
        args = (t_s[part], pressure_kpa[part], angle_deg[part], rate_hz, progress,
                None if missing is None else missing[part], input_hold, noise_model, search, also, graded)
        result = _diagnose(model, *args)
        at_onset = contact_at_onset(model, result, search)
        if at_onset is None:
            return result
        again = _diagnose(at_onset, *args)  # contact from where the residual's torque switches on
        if not again.effects or again.effects[0].name != "contact":
            return result
        onset = at_onset.effects["contact"]
        again.seconds += result.seconds  # both searches'
        again.warnings.append(f"contact's fit started with its onset ({onset['onset_deg']:.1f}°) and "
                              f"exponent ({onset['exponent']:g}) where the residual's torque switches on "
                              "(its onset, fitted apart), and fitted them with its stiffness from there")
        return again

    with threadpool_limits(limits=1, user_api="blas"), workers.using(jobs):  # a long one: excerpt.py
        return excerpt.searched_from_excerpt(run, len(t_s), rate_hz, searched(also), also, progress)


def _diagnose(model: FingerModel, t_s: np.ndarray, pressure_kpa: np.ndarray, angle_deg: np.ndarray,
              rate_hz: float, progress: Progress | None, missing: np.ndarray | None, input_hold: str,
              noise_model: str, search: list[str], asked: Sequence[str] = (),
              graded: bool = True) -> Diagnosis:
    started = time.perf_counter()
    warnings: list[str] = []
    problem = replace(build_problem(model, t_s, pressure_kpa, angle_deg, rate_hz, missing, input_hold),
                      asked=frozenset(asked))  # fitted whatever their screen (search/admission.py)
    held, fit_mask = problem.held_mask, problem.fit_mask
    fitted, scored_held, scored = fit_mask.copy(), held.copy(), fit_mask | held  # raw_error.py's samples
    measured = problem.measured_deg
    if progress:
        progress("simulating the nominal model on the recorded command")
    nominal_angle = problem.simulate(problem.base)
    check_nominal(model, nominal_angle, measured, problem.pressure_kpa)
    params = plain_params(problem, model, warnings)
    if noise_model == "ar":  # the sensor's offset and slow drift are fitted with every model
        problem.noise = noise.nuisance_only(problem.measured_deg.size, rate_hz)
    if progress:
        progress(f"refitting {', '.join(p.label for p in params)} (A held)")
    refit = fit(problem, params, problem.values(params))
    for factor in (0.85, 1.2):  # a second start guards against a wrong ringing frequency
        if stats.ljung_box(refit.residual(problem)[fit_mask], stats.whiteness_lags(rate_hz)).white:
            break
        start = refit.values.copy()
        start[0] *= factor
        other = fit(problem, params, start)
        if other.rss_deg2 < refit.rss_deg2:
            refit = other
    moving = None
    if noise_model == "ar" and (problem.from_start is not None or problem.released):
        # The refitted finger's free motion from the start is a nuisance beside the offset.
        # Where the start is not known to be at rest (from_start), the first decay times
        # count from here on, with its motion from an unknown angle and velocity: a start
        # not quite at rest is absorbed, and what the physics does as the command first
        # moves (a dead zone crossed only then) shows. A release starts where the sensor
        # says, its offset included: the simulation lets go from an angle off the finger's
        # by that offset, whose free motion the offset term leaves in the residual (a clean
        # release read 2° high named an air drag); its motion from a unit angle at rest
        # (the finger was held still) is the start's error.
        moving = noise.start_motion(refit.finger, measured.size, rate_hz)
        if problem.from_start is not None:
            fit_mask, held, blocks = problem.from_start
            problem = replace(problem, fit_mask=fit_mask, held_mask=held, blocks=blocks, from_start=None)
        else:
            moving = moving[:, :1]
        problem = replace(problem, noise=noise.nuisance_only(measured.size, rate_hz, moving))
        refit = fit(problem, params, refit.values)
    lags = stats.whiteness_lags(rate_hz)
    if noise_model == "ar":  # every test from here on runs on the innovations
        problem.noise = noise.estimate(refit.residual(problem), problem.with_skipped(fit_mask | held),
                                       rate_hz, start=moving)
    refit_e = problem.innovations(refit.angle_deg)  # each model's innovations, once
    refit_white = stats.ljung_box(refit_e[fit_mask], lags)
    missing = [name for name in search if name not in model.effects or shape_only(model.effects, name)]
    relative = relative_std(refit)  # what the data alone say (the prior below may hold some)
    unidentified = unpinned(refit)
    if unidentified or far_from_nominal(problem, refit, FAR_FACTOR):
        # What the recording cannot pin is held near the nominal by its prior, so that the
        # effects can still be tested (a closed loop pins only k/N; a slow ramp not B). A
        # refit far from the nominal is checked against the prior too: a slow finger can
        # mimic a dead time on a ramp; the data must ask for the distance, not merely allow it.
        refit = refit_with_prior(problem, params, refit, progress)
        refit_e = problem.innovations(refit.angle_deg)
        refit_white = stats.ljung_box(refit_e[fit_mask], lags)
    lost = raw_error.cannot_follow(problem, refit.angle_deg, fitted, scored)
    # the plain model's adequacy first: no effect is searched on one that cannot follow the data
    selection = Selection(final=refit) if lost else select_screened(problem, refit, missing, progress)
    selection, revised = revisions.revise(problem, refit, selection, missing, lost, progress)
    warnings += revised  # sets past a withdrawn pick, a first-round tie told apart, another path
    if noise_model == "ar" and not lost and (rest := rest_order.search(
            problem, refit, selection, missing, problem.with_skipped(fit_mask | held), (fitted, scored_held),
            progress)) is not None:
        warnings.append(rest.sentence())  # the search again with the noise filter's order at rest
        selection, problem.noise = rest.selection, rest.noise
        refit_e = problem.innovations(refit.angle_deg)
        refit_white = stats.ljung_box(refit_e[fit_mask], lags)
    if unidentified and selection.accepted:
        first = selection.accepted[0]
        free_bic = data_alone_bic(problem, refit, first.fit)
        if free_bic < SIGNIFICANT_BIC:
            warnings.append(f"{first.name} is favoured (ΔBIC {first.delta_bic:.0f}) only while k, B and N "
                            f"are held near the nominal; with them free, the recording is explained as "
                            f"well without it (ΔBIC {free_bic:.0f}): this recording cannot tell "
                            f"{first.name} from a change of k, B and N, so it is not named")
            selection = Selection(rounds=selection.rounds, final=refit)
    final = selection.final or refit
    for label, factor in far_from_nominal(problem, final, REPORT_FACTOR):  # what the report shows
        warnings.append(f"the refitted {label} is {factor:.3g} times the nominal's: this rig is far from "
                        "its model (the fit is not bounded near the nominal; check the model's units)")
    found = [found_effect(problem, c, selection, (fitted, scored_held)) for c in selection.accepted]
    sigma = final.sigma_deg
    residual = refit.residual(problem)
    valid = fit_mask | held
    win = stats.windows(residual, valid, problem.t_s, sigma, rate_hz)
    nominal_e = problem.innovations(nominal_angle)
    u = problem.pressure_kpa[fit_mask]
    first_lag = 1 if problem.input_hold == "zoh" else 0  # see stats.input_independence
    refit_cross = stats.input_independence(refit_e[fit_mask], u, lags, first_lag)
    xcorr = stats.cross_correlation(refit_e[fit_mask], u, lags, rate_hz)

    def judged_final(augmented: Fit) -> tuple[stats.Whiteness, stats.Whiteness, raw_error.RawErrors]:
        """The final model's whiteness and input independence on the innovations, and every
        model against the raw angle, a constant offset each and no drift (raw_error.py)."""
        e = problem.innovations(augmented.angle_deg)[fit_mask]
        return (stats.ljung_box(e, lags), stats.input_independence(e, u, lags, first_lag),
                raw_error.raw_errors(problem, fitted, scored_held, models(nominal_angle, refit, augmented)))

    final_white, final_cross, errors = judged_final(final)
    rmse = errors.heldout_deg
    refit_gain = stats.heldout_z_innovations(nominal_e[held], refit_e[held],
                                             problem.innovation_sigma(refit_e, len(params)))
    refit_bic = stats.delta_bic(problem.fit_rss(nominal_e), problem.fit_rss(refit_e), problem.n_fit,
                                len(params))
    extra: list[FoundEffect] = []
    kept = list(selection.accepted)
    unstable_later = posture_stability.later_unstable(problem, final, selection) if len(found) > 1 else []
    left_beside = len(found) > 1 and not unstable_later and bool(structure_left(final_white, final_cross))
    members = (set_members.standing(problem, final, [c.name for c in selection.accepted], fitted, scored_held)
               if left_beside else None)
    standout = (set_members.stand_out(problem, refit, members, fitted, scored_held)
                if members is not None and not members.all_stand_out else None)
    if members is not None and members.all_stand_out:
        warnings.append(members.sentence())  # named as a set, graded over the structure left
    elif standout is not None:  # the members that stand out, fitted again without the others
        warnings.append(standout.sentence())
        extra = [e for e in found if e.name in standout.dropped]
        selection = replace(selection, rounds=[*selection.rounds, *standout.selection.rounds],
                            accepted=standout.selection.accepted, final=standout.selection.final)
        kept, final = list(selection.accepted), standout.selection.final
        # each against the round it was fitted in (its own selection's: one candidate a round)
        found = [found_effect(problem, c, standout.selection, (fitted, scored_held)) for c in kept]
        final_white, final_cross, errors = judged_final(final)
        rmse = errors.heldout_deg
    elif len(found) > 1 and (structure_left(final_white, final_cross) or unstable_later):
        # Structure outside the library remains even with every effect, or a later effect
        # does not hold across the postures while the first alone does: the later ones may
        # be absorbing it (an even spring taken for gravity, sharp friction's shape taken
        # for air drag, gravity taking a spring's stiffening beyond the cube). A graded
        # answer names the dominant effect alone, fitted alone; the others are reported apart.
        warnings.extend(u.sentence() for u in unstable_later)
        first = selection.accepted[0]
        alone = Selection(rounds=selection.rounds, accepted=[first], final=first.fit)
        extra, found = found[1:], [found_effect(problem, first, alone, (fitted, scored_held))]
        final = first.fit
        kept = [first]
        final_white, final_cross, errors = judged_final(final)
        rmse = errors.heldout_deg
    explained = explained_share(problem, refit, final) if found else 0.0
    if found and any(c.prior_gain > 0.0 for c in kept):  # the refit's distance from the nominal was evidence
        explained = max(explained, prior_share(problem, refit, final))
    round1 = selection.rounds[0].candidates if selection.rounds else []
    inseparable = [c.name for c in round1 if 0.0 < c.separability < SEPARABLE_MIN]
    verdict, notes = judge(unidentified, params, relative, selection, found, (refit_white, refit_cross),
                           (final_white, final_cross),
                           refit_gain, refit_bic, inseparable, warnings,
                           excitation.analyse(problem.pressure_kpa, rate_hz,
                                              refit.value("stiffness_nm_per_rad"),
                                              problem.base.prbm.inertia_kgm2,
                                              refit.value("damping_nms_per_rad")).sentence(), explained,
                           {label: refit.value(label) / getattr(model, label) for label in unidentified})
    if verdict in ("consistent", "parameters_only") and (said := noise_only.plain_structure(
            problem, refit, residual, valid)):
        # the residual is noise only by measures of the noise the AR filter does not make: it
        # alone would take smooth input-driven structure for correlated noise
        warnings.append(said)
        verdict, notes = "unexplained", []
    warnings.extend(drift_said(verdict, problem, refit, (fitted, scored), sigma))  # residual/offset_drift.py
    if selection.ambiguous is not None:
        warnings.extend(posture_stability.posture_advice(selection.ambiguous, problem.measured_deg[fit_mask]))
    if verdict == "missing_physics":
        unstable = posture_stability.check(problem, final, [e.name for e in found])
        mended = ([] if unstable or len(found) < 2
                  else posture_stability.first_alone_unstable(problem, selection))
        warnings.extend(u.sentence() for u in unstable + mended)
        if mended:
            later = " and ".join(e.name for e in found[1:])
            warnings.append(f"with {later} beside it the halves agree, but only as a blend of two forms, "
                            f"as any smooth stiffening can be made over the angles recorded: that does not "
                            f"make {found[0].name} the form")
        if unstable or mended:
            warnings.append("so no effect is named: the mismatch lies outside the library "
                            "(see partial_effects)")
            verdict, notes = "unexplained", []
    # a named effect standing in for physics outside the library (outside_library/checks.py)
    names, masks = [e.name for e in found], (fitted, scored)
    outside = outside_checks(problem, final, names, masks) if verdict in NAMING and found else Outside()
    if said := outside.sentences(names):
        warnings.extend(said)
        if verdict == "missing_physics":
            warnings.append("so no effect is named (see partial_effects)")
            verdict, notes = "unexplained", []
    if verdict == "missing_physics":  # named only where the augmented model follows the raw angle better
        as_fitted, raw_refit = raw_error.effects_follow(problem, nominal_angle, refit, final, fitted,
                                                        scored_held)
        judged = raw_refit.judgement if raw_refit is not None else as_fitted
        names = [e.name for e in found]
        # a tie at the noise, where the effect's evidence is the refit's distance from the
        # nominal (its prior): the raw angle does not contradict the name
        tie = (not judged.follows and any(c.prior_gain > 0.0 for c in kept)
               and judged.ties_at_noise(sigma))
        if tie:
            warnings.append(judged.tie_sentence(names, refit_distance(model, refit)))
        elif raw_refit is not None:
            warnings.append(judged.sentence(names, as_fitted))
        if not judged.follows and not tie:
            verdict, notes = "unexplained", []
        elif raw_refit is not None:  # the name stands on the raw refit: report and write that pair
            refit, final, errors = raw_refit.plain, raw_refit.augmented, raw_refit.errors
            rmse = errors.heldout_deg
            raw_selection = replace(selection, final=final)
            pair = (refit.angle_deg, final.angle_deg)
            found = [found_effect(problem, c, raw_selection, (fitted, scored_held), pair) for c in kept]
    if lost:
        warnings.append(lost)
        verdict, notes = "unexplained", []
    warnings.extend(trade_offs(final, found))
    late = ""  # white innovations, yet structure the noise model took: `dominant` if it stands
    if verdict == "missing_physics" and not structure_left(final_white, final_cross) and (
            late := noise_only.named_structure(problem, final, valid)):
        stands, said = late_structure(found, late, raw_error.RawJudgement.named(errors))
        warnings.append(said)
        verdict, notes = (verdict, notes) if stands else ("unexplained", [])
    partial: list[FoundEffect] = []
    if verdict == "unexplained" and found:
        # a name is given only to what explains the mismatch: these do not, so they are
        # reported apart, and neither the JSON's effects nor --write-model carries them
        partial, found = found + extra, []
    elif extra:
        partial = extra
        warnings.append(f"{', '.join(e.name for e in extra)} also {plural(extra, 'reduce')} the residual "
                        "beside "
                        f"{found[0].name}, but with structure left outside the library they may be "
                        "absorbing it: reported in partial_effects, not named")
    for candidate in (selection.rounds[0].candidates if selection.rounds else []):
        if candidate.separability == 0.0:
            warnings.append(f"this recording cannot reveal {candidate.name}: it has no effect on "
                            "the simulated angle here (see the excitation advice in docs/diagnose.md)")
    left = (structure_left(final_white, final_cross) if found or partial else
            structure_left(refit_white, refit_cross)) or late
    rival, names, ungated = None, [e.name for e in found], [s for s in search if not gated(problem, s)]
    if verdict == "missing_physics" and graded:  # on-request effects, a loop: the closer stands
        tried = rival_check.rivals_to_try(ungated, [*model.effects, *names])
        only = bool(left)  # structure left (`dominant` already): only a rival the raw angle favours
        on_request = rival_check.strongest(problem, refit, final, names, tried, fitted, scored, sigma, only)
        rival = loop_rival.closer(on_request, problem, refit, final, names, fitted, scored, sigma, only)
    if rival is not None:  # a rival the search did not try follows the raw angle as well, or better
        warnings.append(left := rival.sentence())
        if rival.better:  # the named effects do not beat another effect on the raw angle
            verdict, notes, partial, found = "unexplained", [], found + partial, []
    return Diagnosis(verdict, model, refit, final, problem, nominal_angle, found, win, rmse, warnings,
                     selection, sigma, {"refit": refit_white, "augmented": final_white}, xcorr,
                     time.perf_counter() - started, notes, partial, explained, left, outside, errors, rival)
