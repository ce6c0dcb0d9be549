"""The gains of the `mode` request's impedance mode (docs/api.md)."""

from __future__ import annotations

from hand_service.errors import UserError


def impedance_gains(mode: str, stiffness: float | None, damping: float | None) -> tuple[float, float] | None:
    """Impedance mode's (stiffness, damping): stiffness required, damping 0 by default, both >= 0;
    None for the other modes, which take neither."""
    if mode != "impedance":
        if stiffness is not None or damping is not None:
            raise UserError("stiffness_n_per_deg and damping_n_s_per_deg go with mode impedance only")
        return None
    if stiffness is None:
        raise UserError("mode impedance needs stiffness_n_per_deg")
    damping = 0.0 if damping is None else damping
    for name, value in (("stiffness_n_per_deg", stiffness), ("damping_n_s_per_deg", damping)):
        if value < 0.0:
            raise UserError(f"'{name}' must be 0 or more, not {value:g}")
    return stiffness, damping
