"""A loop in the angle: hysteresis in the material, not dry friction.

Dry friction (the library's coulomb_friction) and a loop in the material (an elastomer's
hysteresis) both hold the finger back by about the same torque whatever its speed, and
both turn over with the direction of travel. They differ in how far the finger must move
for them to turn: friction turns at once (within its smoothing velocity, a hair of
travel), a loop over a travel d (Dahl's form, z' = (sign θ' − z)·|θ'|/d: z turns toward the
direction of travel, e-folding every d of angle moved; an elastomer's within degrees).
Where the finger turns, the loop is a spring of stiffness torque/d in series with a slider:
it pulls the finger back elastically before it gives.

Before dry friction is named, the loop is fitted in full in its place (the simulator's own
Dahl loop, csrc/rtcore_sim_plant.c; the other found effects held as fitted; k, B, N, the
loop's torque and d refitted by output error, d from TRAVEL_SHARES of the simulated angle's
range), and compared with the named model on the innovations. The loop's torque stands for
the friction's; d is its one extra parameter. The loop must win by more than
SIGNIFICANT_BIC, and its travel must be a loop's, not a friction's: the loop refitted with
d held at MIN_TRAVEL_SHARE of the range (as near to friction turning at once as the loop
gets) must lose to it by more than SIGNIFICANT_BIC too. Then the answer is "outside the
library", with d.

The fits cost a second or more, and dry friction is named often; they are run only where
a memory helps at all: the loop put in the friction's place as fitted (k, B, N and its
torque the named model's), with a travel of SCREEN_SHARES of the range, must fit better
than with its floor for one of them. Dry friction's misfit only grows with the travel; a
material's loop fits better at a travel of a few per cent of the range.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.rival_fit import fit_rival
from hand_service.diagnose.residual import stats
from hand_service.diagnose.workers import ordered_map
from rtcore.sim import SimFinger

SIGNIFICANT_BIC = 10.0
FRICTION = "coulomb_friction"
TRAVEL_SHARES = (0.01, 0.04, 0.15)  # d's starts, as shares of the simulated angle's range
MIN_TRAVEL_SHARE = 0.002  # d's floor: below it the loop turns as friction does
SCREEN_SHARES = (0.005, 0.01, 0.02, 0.04)  # the screen's travels (module doc)


@dataclass(frozen=True)
class Hysteresis:
    travel_deg: float  # d: the angle over which the loop turns over (e-fold)
    torque_nm: float  # its torque when turned over
    delta_bic: float  # the loop against the named model, both fitted in full
    memory_bic: float  # the loop against itself with d at its floor

    def to_json(self) -> dict:
        return {"travel_deg": self.travel_deg, "torque_nm": self.torque_nm, "delta_bic": self.delta_bic,
                "memory_delta_bic": self.memory_bic}

    def sentence(self) -> str:
        return (f"the torque that holds the finger back turns over within about {self.travel_deg:.2g}° of "
                f"travel after each turn, not at once as dry friction's does: a loop in the angle "
                f"(hysteresis in the material, {self.torque_nm:.3g} N·m when turned over) explains the "
                f"residual better than {FRICTION} (ΔBIC {self.delta_bic:.0f}, both fitted in full; "
                f"ΔBIC {self.memory_bic:.0f} against the same loop turning within a hair of travel); "
                "hysteresis is outside the library")


def loop_finger(finger: SimFinger, torque_nm: float, travel_deg: float) -> SimFinger:
    """`finger` with the simulator's loop (csrc/rtcore_sim.h: hysteresis_*)."""
    return dataclasses.replace(finger, hysteresis_torque_nm=torque_nm, hysteresis_travel_deg=travel_deg)


def hysteresis_check(problem: Problem, final: Fit, found: list[str]) -> Hysteresis | None:
    """The loop fitted in place of dry friction, when `found` names it; the loop when it wins
    (module doc), else None. k, B and N are held by the same prior as `final` was (the
    engine's, or the nominal's where the effect's fit needed it): the gains are the data's."""
    if FRICTION not in found:
        return None
    torque0_nm = max(final.value(FRICTION), 1e-9)
    span_deg = max(float(np.ptp(final.angle_deg[problem.fit_mask])), 1e-9)
    floor_deg = MIN_TRAVEL_SHARE * span_deg
    without = final.without(problem, [FRICTION])

    def as_fitted(travel_deg: float) -> float:
        """The innovations' RSS of the loop in the friction's place, nothing refitted."""
        angle = problem.simulate(loop_finger(without, torque0_nm, travel_deg))
        return problem.fit_rss(problem.innovations(angle))

    if min(as_fitted(share * span_deg) for share in SCREEN_SHARES) >= as_fitted(floor_deg):
        return None  # a memory does not help at all: friction's, not a loop's

    def one(travel0_deg: float, free: bool) -> tuple[float, float, float]:
        """(innovations' RSS, d, torque) of the loop fitted from d = travel0_deg (held there
        unless `free`): the torque over the friction's, and log(d / travel0_deg)."""
        def travel(x: np.ndarray) -> float:
            return travel0_deg * float(np.exp(x[1])) if free else travel0_deg

        lower = np.array([1e-3, np.log(floor_deg / travel0_deg)] if free else [1e-3])
        upper = np.array([1e3, np.log(span_deg / travel0_deg)] if free else [1e3])
        rss, x = fit_rival(problem, final, [FRICTION], np.array([1.0, 0.0] if free else [1.0]), lower, upper,
                           lambda f, x: loop_finger(f, x[0] * torque0_nm, travel(x)))
        return rss, travel(x), float(x[0] * torque0_nm)

    jobs = [(share * span_deg, True) for share in TRAVEL_SHARES] + [(floor_deg, False)]
    fits = ordered_map(lambda job: one(*job), jobs)  # each start its own fit
    rss, travel_deg, torque_nm = min(fits[:-1])
    named_rss = problem.fit_rss(problem.innovations(final.angle_deg))
    gain = stats.delta_bic(named_rss, rss, problem.n_fit, 1)  # d: the torque stands for the friction's
    memory = stats.delta_bic(fits[-1][0], rss, problem.n_fit, 1)
    if not (gain > SIGNIFICANT_BIC and memory > SIGNIFICANT_BIC):
        return None
    return Hysteresis(travel_deg, torque_nm, gain, memory)
