"""A loop in the angle as a rival before the grade `complete`: a hysteresis loop in Dahl's form
(the library's `hysteresis`, which the search's screen may keep out) fitted in place of every
named effect.

A material whose torque lags the angle by a loop (an elastomer's hysteresis) holds the
finger off its spring's line by a torque that turns over within some travel after each
reversal. Over a recording whose command jumps between levels, where the finger comes to
rest from either side, a static map that bends (gravity's sine, a cubic spring) can take
what the loop does, follow the recorded angle to its noise, and be graded `complete`
(docs/results.md §12.36, §12.42). material_hysteresis.py puts a loop in dry friction's
place only; here, wherever the verdict would be `missing_physics`, beside the library's rivals
(rival_check.py; of those that stand, the closer is said), the simulator's loop (Dahl's
form, material_hysteresis.loop_finger) is fitted in place of all the named effects, k, B, N,
its torque and its travel refitted by output error (rival_fit.rival_model), and judged as a
library rival is: it must gain on the
plain model by more than SIGNIFICANT_BIC on the innovations (its two parameters charged),
lose to the named model there by no more (the search's margin for a tie: a loop that trails
the named model by more would not be named had it been searched), hold a loop's memory (the
same loop with its travel held at material_hysteresis's floor, where it turns over as
friction does, loses to it by more than SIGNIFICANT_BIC: a loop that is a library friction
is no other physics than the friction), and the raw angle must not find it worse than the named
model (raw_difference.py). Then the grade is `dominant`, and the loop is said (where
structure is left, only a loop the raw angle favours: rival_check.py's module doc).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_difference import LossDifference, loss_difference
from hand_service.diagnose.fitting.raw_error import raw_misfit_deg, raw_rms_deg
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.material_hysteresis import MIN_TRAVEL_SHARE, loop_finger
from hand_service.diagnose.outside_library.rival_fit import rival_model
from hand_service.diagnose.residual import stats
from hand_service.diagnose.search.forward_selection import SIGNIFICANT_BIC
from hand_service.diagnose.search.rival_check import Rival
from hand_service.diagnose.workers import ordered_map

NAME = "hysteresis_loop"
# The loop's start: its torque as a share of the spring's torque over the simulated angle's
# range, its travel as a share of that range (the fit moves both; bounds as below).
TORQUE_SHARE = 0.05
TRAVEL_SHARE = 0.1
TORQUE_BOUNDS = (1e-3, 1e3)  # factors of the start


def loop_in_place(problem: Problem, refit: Fit, final: Fit, named: Sequence[str], fitting: np.ndarray,
                  scored: np.ndarray, noise_deg: float, better_only: bool = False) -> Rival | None:
    """The loop fitted in place of the `named` effects of `final` (module doc): a Rival when
    it stands, else None. `refit` is the plain model, `noise_deg` the sensor's noise the fits
    estimate. `better_only` (structure left: only a rival the raw angle favours counts) fits
    the memory's loop only where the free loop follows the raw angle better."""
    span_deg = float(np.ptp(final.angle_deg[problem.fit_mask]))
    if not named or span_deg <= 0.0:
        return None
    torque0_nm = TORQUE_SHARE * final.finger.prbm.stiffness_nm_per_rad * np.radians(span_deg)
    travel0_deg, floor_deg = TRAVEL_SHARE * span_deg, MIN_TRAVEL_SHARE * span_deg

    def one(free: bool):
        def travel(x: np.ndarray) -> float:
            return travel0_deg * float(np.exp(x[1])) if free else floor_deg

        lower = np.array([TORQUE_BOUNDS[0], np.log(floor_deg / travel0_deg)] if free else [TORQUE_BOUNDS[0]])
        upper = np.array([TORQUE_BOUNDS[1], np.log(span_deg / travel0_deg)] if free else [TORQUE_BOUNDS[1]])
        x0 = np.array([1.0, 0.0] if free else [1.0])
        fitted = rival_model(problem, final, list(named), x0, lower, upper,
                             lambda f, x: loop_finger(f, x[0] * torque0_nm, travel(x)))
        return fitted, travel(fitted.extra)

    named_err = raw_misfit_deg(problem, final.angle_deg, fitting, scored)

    def against_named(angle_deg: np.ndarray) -> LossDifference:
        return loss_difference(named_err, raw_misfit_deg(problem, angle_deg, fitting, scored))

    if better_only:  # the free loop first: the memory's only where it is better
        loop, travel_deg = one(True)
        if not (np.all(np.isfinite(loop.angle_deg)) and against_named(loop.angle_deg).b_better):
            return None
        friction = one(False)[0]
    else:
        (loop, travel_deg), (friction, _) = ordered_map(one, [True, False])
        if not np.all(np.isfinite(loop.angle_deg)):
            return None
    plain_rss = problem.fit_rss(problem.innovations(refit.angle_deg))
    gain = stats.delta_bic(plain_rss, loop.rss, problem.n_fit, 2)
    memory = stats.delta_bic(friction.rss, loop.rss, problem.n_fit, 1)
    # against the named model on the innovations: as a round weighs a tie, its parameters charged
    named_params = sum(p.is_effect for p in final.params)
    tie = stats.delta_bic(problem.fit_rss(problem.innovations(final.angle_deg)), loop.rss, problem.n_fit,
                          2 - named_params) > -SIGNIFICANT_BIC
    estimate = {"torque_nm": float(loop.extra[0] * torque0_nm), "travel_deg": travel_deg}
    significant = gain > SIGNIFICANT_BIC and memory > SIGNIFICANT_BIC and tie
    rival = Rival(NAME, tuple(named), estimate, gain, significant,
                  raw_rms_deg(problem, loop.angle_deg, fitting, scored),
                  raw_rms_deg(problem, final.angle_deg, fitting, scored), noise_deg,
                  against_named(loop.angle_deg),
                  loop=True)
    return rival if rival.stands else None


def closer(library: Rival | None, problem: Problem, refit: Fit, final: Fit, named: Sequence[str],
           fitting: np.ndarray, scored: np.ndarray, noise_deg: float,
           better_only: bool = False) -> Rival | None:
    """Of the library's rival that stands (`library`, rival_check.strongest) and the loop in
    place of the `named` effects, the one that stands closer to the raw angle, or None. No
    loop where `hysteresis` is named: the named model holds one already. `better_only`:
    loop_in_place's."""
    if "hysteresis" in named:
        return library
    loop = loop_in_place(problem, refit, final, named, fitting, scored, noise_deg, better_only)
    return min((r for r in (library, loop) if r is not None), key=lambda r: r.rival_raw_deg, default=None)
