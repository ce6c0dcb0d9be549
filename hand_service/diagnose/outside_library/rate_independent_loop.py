"""A lag that does not grow with the rate: a hysteresis loop, not a valve lag or a dead time.

A valve lag τ or a dead time holds the finger behind the command by about τ times the
command's rate: twice as fast a ramp, twice the lag. A rate-independent loop (hysteresis
in the material, backlash, a friction that builds up over the travel) holds it behind by
an amount that depends on the path alone: how far the command has moved since it last
turned. On a recording whose command moves at one rate the two are the same; where the
rate varies they are not. Before a valve lag or a dead time is named, its signature is
tested against a loop along the command's path,

    z' = (sign(p') − z) · |p'| / d  (Dahl's form: z turns over within about d kPa of travel),
    d at 0.5 % to 50 % of the command's range,

the loop linearised as contact_onset.py's torques are (its angle response through the refitted
finger's own linear dynamics), the timed effect as fitted (the model with it less the model
without it, scaled by a free factor), each regressed with k, B, N and the other found
effects on the prewhitened residual. The lag's exact signature against a linearised loop
leans toward the lag. When the loop explains the residual better by more than its extra
parameter (d) and SIGNIFICANT_BIC, the lag was standing in for a loop: the answer is
"outside the library", with d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit, sensitivity
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.contact_onset import incumbent_projection, linear_finger, through
from hand_service.diagnose.residual import stats

SIGNIFICANT_BIC = 10.0
TIMED = ("valve_lag", "dead_time")  # the library's effects that hold the finger back by a time
SPANS = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)  # d, as a share of the command's range
EXTRA_PARAMS = 1  # d: the loop's size stands for the lag's


@dataclass(frozen=True)
class Loop:
    travel_kpa: float  # d: the command's travel over which the loop turns over
    delta_bic: float  # the loop against the timed effect, both linearised
    replaces: str  # the timed effect it explains better

    def to_json(self) -> dict:
        return {"travel_kpa": self.travel_kpa, "delta_bic": self.delta_bic, "replaces": self.replaces}

    def sentence(self) -> str:
        return (f"the finger lags the command by an amount that does not grow with the command's rate: "
                f"a loop that turns over within about {self.travel_kpa:.3g} kPa of the command's travel "
                f"explains the residual better than {self.replaces} (ΔBIC {self.delta_bic:.0f}, the loop "
                "linearised), whose lag would be proportional to the rate; a rate-independent loop "
                "(hysteresis, backlash) is outside the library")


def path_state(command_kpa: np.ndarray, travel_kpa: float) -> np.ndarray:
    """Dahl's state along the command's path: z moves toward the direction of travel, e-fold
    every `travel_kpa` moved, and stays where it is while the command holds. Within a run of
    one direction z = s + (z0 − s)·exp(−(travel since the run began) / d), so the loop over
    the runs is only as long as the number of turns. z starts at 0 (a finger that starts
    pressurised and held most likely starts at +1: a start that costs the loop, never the
    lag)."""
    step = np.diff(command_kpa, prepend=command_kpa[0])
    direction = np.sign(step)
    moving = np.flatnonzero(direction)
    z = np.zeros(command_kpa.size)
    if moving.size == 0:
        return z
    # runs of one direction among the moving samples
    turns = np.flatnonzero(np.diff(direction[moving]) != 0) + 1
    starts = np.concatenate(([0], turns))
    stops = np.concatenate((turns, [moving.size]))
    level = 0.0
    for a, b in zip(starts, stops, strict=True):
        idx = moving[a:b]
        s = direction[idx[0]]
        travel = np.cumsum(np.abs(step[idx]))
        values = s + (level - s) * np.exp(-travel / travel_kpa)
        z[idx] = values
        level = float(values[-1])
    # held samples keep the last value reached (forward fill over the moving ones)
    last = np.maximum.accumulate(np.where(direction != 0, np.arange(z.size), -1))
    return np.where(last >= 0, z[np.maximum(last, 0)], 0.0)


def loop_check(problem: Problem, final: Fit, found: list[str]) -> Loop | None:
    """The loop family in place of each timed effect in `found` (TIMED), the others kept;
    the best loop when it wins by more than SIGNIFICANT_BIC, else None."""
    timed = [n for n in found if n in TIMED]
    command = problem.pressure_kpa
    span = float(np.ptp(command))
    if not timed or span <= 0.0:
        return None
    detrend = problem.noise.detrend
    linear = linear_finger(problem, final)
    loops = [detrend(linear.response_deg(path_state(command, share * span))) for share in SPANS]
    # every fitted parameter's sensitivity, a timed effect's only where it stays beside another
    columns = {(p.label, p.member): detrend(sensitivity(problem, p, final.finger, final.angle_deg))
               for p in final.params if p.label not in timed or len(timed) > 1}
    best: Loop | None = None
    for name in timed:
        loop = _against(problem, final, name, columns, loops, span)
        if loop is not None and (best is None or loop.delta_bic > best.delta_bic):
            best = loop
    return best if best is not None and best.delta_bic > SIGNIFICANT_BIC else None


def _against(problem: Problem, final: Fit, name: str, columns: dict[tuple[str, str], np.ndarray],
             loops: list[np.ndarray],
             span: float) -> Loop | None:
    """The best loop (`loops`: each SPANS' response, detrended) in place of the timed effect
    `name`, with its ΔBIC over it; `columns`: every fitted parameter's sensitivity."""
    mask = problem.fit_mask
    shared = [column for (label, _), column in columns.items() if label != name]
    alone = problem.simulate(final.without(problem, [name]))
    target = problem.misfit(alone)
    lag = problem.noise.detrend(final.angle_deg - alone)  # the timed effect's whole signature, as fitted
    fitted, a = incumbent_projection(problem, shared, lag, target)  # the AR filter: the lag's residual
    rss_lag = fitted.rss(through(lag, a)[mask][:, None])
    best_rss, best_travel = np.inf, 0.0
    for share, column in zip(SPANS, loops, strict=True):
        rss = fitted.rss(through(column, a)[mask][:, None])
        if rss < best_rss:
            best_rss, best_travel = rss, share * span
    if not np.isfinite(best_rss) or best_rss <= 0.0:
        return None
    return Loop(best_travel, stats.delta_bic(rss_lag, best_rss, int(mask.sum()), EXTRA_PARAMS), name)
