"""The battery's search for an effect's strength: the size at which what the plain refit
leaves of it (its visibility, on the noise's scale) meets a target (cases.build)."""

from __future__ import annotations

import math


def calibrate(
    evaluate,
    s: float,
    v: float,
    traj,
    meas,
    lo: float,
    hi: float,
    target: float,
    tol: float = 1.12,
    iterations: int = 12,
):
    """Solves visibility(s) = target in log-log: secant steps until the root is bracketed,
    then regula falsi with a bisection when one side stalls."""
    below: tuple[float, float] | None = None  # (log s, log v) with v < target
    above: tuple[float, float] | None = None
    best = (abs(math.log(max(v, 1e-12) / target)), s, v, traj, meas)
    slope = 1.0
    last = None
    for _ in range(iterations):
        if abs(math.log(max(v, 1e-12) / target)) < math.log(tol):
            break
        ls, lv = math.log(s), math.log(max(v, 1e-12))
        if lv < math.log(target):
            below = (ls, lv)
        else:
            above = (ls, lv)
        if last is not None and abs(ls - last[0]) > 1e-9 and abs(lv - last[1]) > 1e-6:
            slope = min(max((lv - last[1]) / (ls - last[0]), 0.25), 4.0)
        last = (ls, lv)
        if below is not None and above is not None:
            (la, va), (lb, vb) = below, above
            x = la + (math.log(target) - va) * (lb - la) / (vb - va) if vb != va else 0.5 * (la + lb)
            # keep inside the bracket, away from its ends
            x = min(
                max(x, la + 0.1 * (lb - la) if lb > la else lb + 0.1 * (la - lb)),
                la + 0.9 * (lb - la) if lb > la else lb + 0.9 * (la - lb),
            )
        else:
            x = ls + (math.log(target) - lv) / slope
        new = min(max(math.exp(x), lo), hi)
        if new == s:
            break  # pinned at a bound
        s = new
        v, traj, meas = evaluate(s)
        err = abs(math.log(max(v, 1e-12) / target))
        if err < best[0]:
            best = (err, s, v, traj, meas)
    _, s, v, traj, meas = best
    return s, v, traj, meas
