"""What decides that an effect is determined and that it carries itself.

An effect whose size trades with its shape (a contact's K, whose units change with its
exponent n) is judged on the quantity the recording fixes (Effect.derived_size: a contact's
spring torque at the deepest angle reached), its standard error by the delta method from
the joint fit's covariance. An effect with parameters that only refine it (Effect.refining:
a contact's damper) must also beat the plain model with those held at neutral."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit

RELATIVE_STEP = 1e-6  # the delta method's central differences, of each parameter's scale


@dataclass(frozen=True)
class SizeEstimate:
    value: float
    std: float
    unit: str
    what: str  # "" for the effect's size itself


def deepest_deg(fit: Fit) -> float:
    """The deepest angle the fitted finger reaches over the recording (the model's angle
    follows the recorded one without its noise)."""
    return float(np.max(fit.angle_deg))


def derived_size(fit: Fit, name: str) -> SizeEstimate | None:
    """Effect `name`'s derived size in `fit` and its standard error (∇fᵀ·Σ·∇f over the
    effect's parameters, Σ the fit's covariance, k, B and N marginalised in it), or None
    where the effect is judged on its size."""
    spec = fx.BY_NAME[name]
    mine = [i for i, p in enumerate(fit.params) if p.label == name]
    members = [fit.params[i].member or spec.param for i in mine]
    values = {**spec.full({}), **{m: float(fit.values[i]) for m, i in zip(members, mine, strict=True)}}
    deepest = deepest_deg(fit)
    size = spec.derived_size(values, deepest)
    if size is None:
        return None
    gradient = np.zeros(len(mine))
    for j, (member, i) in enumerate(zip(members, mine, strict=True)):
        step = RELATIVE_STEP * fit.params[i].scale
        up = spec.derived_size({**values, member: values[member] + step}, deepest)
        down = spec.derived_size({**values, member: values[member] - step}, deepest)
        assert up is not None and down is not None
        gradient[j] = (up.value - down.value) / (2.0 * step)
    cov = fit.covariance()[np.ix_(mine, mine)]
    live = gradient != 0.0  # a parameter the quantity does not depend on adds nothing, even unknown
    with np.errstate(invalid="ignore", over="ignore"):
        variance = float(gradient[live] @ cov[np.ix_(live, live)] @ gradient[live])
    std = float(np.sqrt(variance)) if np.isfinite(variance) and variance >= 0.0 else np.inf
    return SizeEstimate(size.value, std, size.unit, size.what)


def without_refining(fit: Fit, name: str) -> tuple[list, list[float]] | None:
    """`fit`'s parameters and values without effect `name`'s refining parameters (the
    simulated finger then holds them at neutral), or None where it has none in the fit."""
    refining = set(fx.BY_NAME[name].refining)
    keep = [i for i, p in enumerate(fit.params) if not (p.label == name and p.member in refining)]
    if len(keep) == len(fit.params):
        return None
    return [fit.params[i] for i in keep], [float(fit.values[i]) for i in keep]
