"""The gains of the `mode` request's impedance mode (docs/api.md), and their stable range.

Impedance mode is force control on the Moore-Penrose estimate with the reference
F = K·(θ_ref − θ) + D·(θ'_ref − θ'): the feedforward cancels the finger's own spring k
through the estimate and puts in its place a virtual joint stiffness r·K·(180/π) (r the
lever arm, K in N per deg) and a virtual joint damping r·D·(180/π). Both act through the
valve's lag, the dead time, the filters and the 100 Hz step, so the loop is stable only up
to a limit. Simulated on the shipped hand (hand_service.pinch.compliance.free_step, a
10° reference step with no contact; docs/replicate.md), the five fingers lose stability
at a virtual joint stiffness of 1.1 to 1.4 times k, and, at K = K_max, at a virtual joint
damping of 0.53 to 1.0 times the finger's critical damping sqrt(k·A). The bounds keep a
margin of about 2 on both: K_max = 0.5·k / (r·180/π), D_max = 0.25·sqrt(k·A) / (r·180/π),
from the controller's finger model (the profile's).
"""

from __future__ import annotations

import math

from hand_service.config.model import FingerModel
from hand_service.errors import UserError

STIFFNESS_SHARE_OF_K = 0.5
DAMPING_SHARE_OF_CRITICAL = 0.25


def stiffness_max_n_per_deg(stiffness_nm_per_rad: float, lever_arm_m: float) -> float:
    return STIFFNESS_SHARE_OF_K * stiffness_nm_per_rad / (lever_arm_m * 180.0 / math.pi)


def damping_max_n_s_per_deg(stiffness_nm_per_rad: float, inertia_kgm2: float, lever_arm_m: float) -> float:
    critical_nms_per_rad = math.sqrt(stiffness_nm_per_rad * inertia_kgm2)
    return DAMPING_SHARE_OF_CRITICAL * critical_nms_per_rad / (lever_arm_m * 180.0 / math.pi)


def gain_limits(model: FingerModel) -> tuple[float, float]:
    """(K_max in N/deg, D_max in N·s/deg) for a finger model."""
    k, r, a = model.stiffness_nm_per_rad, model.lever_arm_m, model.inertia_kgm2
    return stiffness_max_n_per_deg(k, r), damping_max_n_s_per_deg(k, a, r)


def impedance_gains(mode: str, stiffness: float | None, damping: float | None,
                    limits: dict[str, tuple[float, float]] | None = None) -> tuple[float, float] | None:
    """Impedance mode's (stiffness, damping): stiffness required, damping 0 by default, both
    finite, 0 or more and at most each finger's limit (`limits`: finger -> (K_max, D_max));
    None for the other modes, which take neither."""
    if mode != "impedance":
        if stiffness is not None or damping is not None:
            raise UserError("stiffness_n_per_deg and damping_n_s_per_deg go with mode impedance only")
        return None
    if stiffness is None:
        raise UserError("mode impedance needs stiffness_n_per_deg")
    damping = 0.0 if damping is None else damping
    for name, value in (("stiffness_n_per_deg", stiffness), ("damping_n_s_per_deg", damping)):
        if not math.isfinite(value):
            raise UserError(f"'{name}' must be a finite number, not {value}")
        if value < 0.0:
            raise UserError(f"'{name}' must be 0 or more, not {value:g}")
    for finger, (k_max, d_max) in (limits or {}).items():
        if stiffness > k_max:
            raise UserError(f"'stiffness_n_per_deg' = {stiffness:g} is above {finger}'s stable limit "
                            f"{k_max:.3g} N/deg (half its own joint stiffness; docs/api.md)")
        if damping > d_max:
            raise UserError(f"'damping_n_s_per_deg' = {damping:g} is above {finger}'s stable limit "
                            f"{d_max:.3g} N·s/deg (a quarter of its critical damping; docs/api.md)")
    return stiffness, damping
