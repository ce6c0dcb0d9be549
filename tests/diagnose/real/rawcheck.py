"""The raw RMS error of `diagnose`'s answer, measured here and not by `hand_service`: the
model simulated from the recorded command alone (odefit's RK4, the recorded initial state, no
sensor offset, no drift) against the raw angle.

Issue 44 asks that an effect be named only when the augmented model beats the plain one on
the raw signal. Today's JSON reports held-out errors after a free offset; this module gives
the table the raw figure for the effects odefit can simulate (`cubic_stiffness`,
`coulomb_friction`, `dead_time`, and a dead time with one of the other two); None otherwise.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tests.diagnose.real.odefit import DEG, FloatArray, Recording, initial_state, simulate

KIND_OF = {"cubic_stiffness": ("cubic", "k3_nm_per_rad3"), "coulomb_friction": ("coulomb", "torque_nm")}


def delayed(rec: Recording, delay_s: float) -> FloatArray:
    """The command as the finger sees it delay_s later (linear between samples, held before t0)."""
    return np.interp(rec.t - delay_s, rec.t, rec.p, left=rec.p[0])


def rms_of(rec: Recording, model: dict[str, float], effects: dict[str, float], hold: str) -> float | None:
    """Raw RMS (deg) of the model with `effects` ({name: value}) simulated from the command."""
    a = model["inertia_kgm2"]
    kinds = [name for name in effects if name != "dead_time"]
    if len(kinds) > 1 or any(name not in KIND_OF for name in kinds):
        return None
    kind, c = ("linear", 0.0) if not kinds else (KIND_OF[kinds[0]][0], effects[kinds[0]] / a)
    p = delayed(rec, effects["dead_time"]) if "dead_time" in effects else rec.p
    theta0, omega0 = initial_state(rec)
    row = np.array([model["damping_nms_per_rad"] / a, model["stiffness_nm_per_rad"] / a,
                    model["pressure_gain_nm_per_kpa"] / a, c, theta0, omega0])
    sim = simulate(row, p, rec.dt, kind, hold, max_step=min(rec.dt / 2, 5e-3))[0] / DEG
    err = sim - rec.theta_deg
    return float(np.sqrt(np.mean(err ** 2))) if np.all(np.isfinite(err)) else float("inf")


def raw_rms(rec: Recording, nominal: dict[str, float], result: dict[str, Any],
            hold: str) -> dict[str, float | None]:
    """{"nominal": the nominal model's raw RMS, "augmented": diagnose's refit with its named
    effects (None when it named none or odefit cannot simulate them)}."""
    named = {str(e["name"]): float(next(iter((e.get("params") or {}).values()), np.nan))
             for e in result.get("effects") or []}
    refit = result.get("refit")
    augmented = rms_of(rec, refit, named, hold) if named and isinstance(refit, dict) else None
    return {"nominal": rms_of(rec, nominal, {}, hold), "augmented": augmented}
