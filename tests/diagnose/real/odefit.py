"""The independent fitter of the real-rig fixtures (convert.py writes them, test_real_rigs.py
holds diagnose against it): an RK4 output-error fit of A·θ'' + B·θ' + k·θ + f(θ, θ') = N·p
with the effect's term (linear, cubic or Coulomb), and the fixtures' CSV and model files.

Nothing here imports `hand_service`: it is a separate implementation, so a test can hold
`diagnose` against it. Angle data determine only B/A, k/A, N/A and f/A, so each rig gets a
chosen A, and every parameter is A times the normalised value fitted here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

FloatArray = NDArray[np.float64]

DEG = math.pi / 180.0
OMEGA_S_DEG = 2.0  # the project's dry-friction smoothing: Tc·tanh(θ'/2 deg/s) (docs/formats.md §2.1)
KINDS = ("linear", "cubic", "coulomb")


@dataclass(frozen=True)
class Recording:
    """One recording in the project's units: t (s), command p (kPa), angle (deg)."""

    t: FloatArray
    p: FloatArray
    theta_deg: FloatArray

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.t)))


@dataclass
class OdeFit:
    """θ'' = −b·θ' − k·θ − c·g(θ, θ') + n·p, θ in rad; g is θ³ (cubic) or tanh(θ'/ω_s) (coulomb)."""

    kind: str
    b: float  # B/A, 1/s
    k: float  # k/A, 1/s²
    n: float  # N/A, rad/(s²·kPa)
    c: float  # effect/A: k3/A (1/(s²·rad²)) or Tc/A (rad/s²); 0 for linear
    theta0: float  # initial state, rad and rad/s
    omega0: float
    rmse_deg: float
    std: dict[str, float] = field(default_factory=dict)

    def model(self, inertia: float) -> dict[str, float]:
        return {"inertia_kgm2": inertia, "damping_nms_per_rad": inertia * self.b,
                "stiffness_nm_per_rad": inertia * self.k, "pressure_gain_nm_per_kpa": inertia * self.n}


# ---------------------------------------------------------------------------------------------
# Output-error simulation (RK4, command held over each sample) and its least-squares fit.


def nonlinear_term(kind: str) -> Callable[[FloatArray, FloatArray], FloatArray]:
    if kind == "cubic":
        return lambda th, om: th ** 3
    if kind == "coulomb":
        return lambda th, om: np.tanh(om / (OMEGA_S_DEG * DEG))
    return lambda th, om: np.zeros_like(th)


def simulate(params: FloatArray, p: FloatArray, dt: float, kind: str, hold: str = "zoh",
             max_step: float = 5e-4) -> FloatArray:
    """Simulate a batch of parameter rows [b, k, n, c, θ0, ω0]; returns θ (rad), shape (rows, samples).

    `hold` is how the command goes between samples: "zoh" held, "point" linear (a command that
    changed continuously and was sampled, like diagnose's --input-hold point).
    """
    params = np.atleast_2d(params)
    b, k, n, c = (params[:, i] for i in range(4))
    theta = params[:, 4].copy()
    omega = params[:, 5].copy()
    g = nonlinear_term(kind)
    sub = max(1, math.ceil(dt / max_step - 1e-9))
    h = dt / sub
    out = np.empty((params.shape[0], p.size))

    def acc(th: FloatArray, om: FloatArray, u: float) -> FloatArray:
        return n * u - b * om - k * th - c * g(th, om)

    nxt = np.append(p[1:], p[-1]) if hold == "point" else p
    for i, (u0, u1) in enumerate(zip(p.tolist(), nxt.tolist(), strict=True)):
        out[:, i] = theta
        slope = (u1 - u0) / sub
        for j in range(sub):
            ua, um, ub = u0 + slope * j, u0 + slope * (j + 0.5), u0 + slope * (j + 1)
            a1 = acc(theta, omega, ua)
            t2, o2 = theta + 0.5 * h * omega, omega + 0.5 * h * a1
            a2 = acc(t2, o2, um)
            t3, o3 = theta + 0.5 * h * o2, omega + 0.5 * h * a2
            a3 = acc(t3, o3, um)
            t4, o4 = theta + h * o3, omega + h * a3
            a4 = acc(t4, o4, ub)
            theta = theta + h / 6.0 * (omega + 2.0 * o2 + 2.0 * o3 + o4)
            omega = omega + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return out


def equation_error_start(rec: Recording, kind: str) -> FloatArray:
    """A starting point: least squares on the ODE with central-difference derivatives."""
    th = rec.theta_deg * DEG
    dt = rec.dt
    om = (th[2:] - th[:-2]) / (2 * dt)
    ac = (th[2:] - 2 * th[1:-1] + th[:-2]) / dt ** 2
    x = th[1:-1]
    u = 0.5 * (rec.p[:-2] + rec.p[1:-1])
    cols = [-om, -x, u]
    if kind != "linear":
        cols.append(-nonlinear_term(kind)(x, om))
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), ac, rcond=None)
    b, k, n = coef[:3]
    c = coef[3] if kind != "linear" else 0.0
    return np.array([max(b, 1e-3), max(k, 1e-3), n, c, th[0], om[0]])


def initial_state(rec: Recording) -> tuple[float, float]:
    """θ (rad) and θ' (rad/s) at the first sample, from a line through the first 10 ms."""
    n = max(3, round(0.01 / rec.dt))
    slope, icpt = np.polyfit(rec.t[:n] - rec.t[0], rec.theta_deg[:n] * DEG, 1)
    return float(icpt), float(slope)


def fit_ode(rec: Recording, kind: str, start: FloatArray | None = None, skip_s: float = 0.0,
            hold: str = "zoh", free_initial: bool = True, stiffness: float | None = None,
            max_step: float = 5e-4, physical: bool = False) -> OdeFit:
    """Output-error least squares of [b, k, n, c, θ0, ω0] (c fixed at 0 for `linear`).

    With `free_initial` False the initial state is the data's (`initial_state`), not fitted;
    `stiffness` holds k/A at a given value (an axis without a spring: 0); `max_step` (s) is
    the longest RK4 step; `physical` keeps B/A and k/A at or above zero (a nominal finger that
    neither gains energy nor has a negative spring).
    """
    p0 = equation_error_start(rec, kind) if start is None else np.asarray(start, dtype=float).copy()
    free = [0, 1, 2, 3, 4, 5]
    if kind == "linear":
        p0[3] = 0.0
        free.remove(3)
    if stiffness is not None:
        p0[1] = stiffness
        free.remove(1)
    if not free_initial:
        p0[4], p0[5] = initial_state(rec)
        free = [i for i in free if i < 4]
    scale = np.maximum(np.abs(p0[free]), 1e-6)
    if kind != "linear" and abs(p0[3]) < 1e-12:
        scale[free.index(3)] = 0.1 * abs(p0[1])  # an effect started at neutral: step on k's scale
    if 1 in free:
        scale[free.index(1)] = max(abs(p0[1]), 1e-3)
    if free_initial:
        scale[free.index(4)] = max(abs(p0[4]), 10 * DEG)
        scale[free.index(5)] = max(abs(p0[5]), 100 * DEG)
    y = rec.theta_deg
    keep = rec.t - rec.t[0] >= skip_s

    def full(z: FloatArray) -> FloatArray:
        q = p0.copy()
        q[free] = z * scale
        return q

    def residual(z: FloatArray) -> FloatArray:
        return (simulate(full(z), rec.p, rec.dt, kind, hold, max_step)[0] / DEG - y)[keep]

    def jacobian(z: FloatArray) -> FloatArray:
        step = 1e-6
        rows = np.repeat(full(z)[None, :], len(free) + 1, axis=0)
        for j, idx in enumerate(free):
            rows[j + 1, idx] += step * scale[j]
        sims = simulate(rows, rec.p, rec.dt, kind, hold, max_step) / DEG
        return ((sims[1:] - sims[0]) / step).T[keep]

    lower = np.full(len(free), -np.inf)
    if physical:
        for idx in (0, 1):
            if idx in free:
                p0[idx] = max(p0[idx], 1e-3 * scale[free.index(idx)])
                lower[free.index(idx)] = 0.0
    sol = least_squares(residual, p0[free] / scale, jac=jacobian, bounds=(lower, np.inf),
                        x_scale="jac", xtol=1e-10, ftol=1e-10, max_nfev=200)
    q = full(sol.x)
    dof = max(1, int(keep.sum()) - len(free))
    sigma2 = float(sol.fun @ sol.fun) / dof
    try:
        cov = np.linalg.inv(sol.jac.T @ sol.jac) * sigma2
        std_z = np.sqrt(np.diag(cov))
    except np.linalg.LinAlgError:
        std_z = np.full(len(free), np.nan)
    names = ["b", "k", "n", "c", "theta0", "omega0"]
    std = {names[idx]: float(std_z[j] * scale[j]) for j, idx in enumerate(free)}
    return OdeFit(kind, float(q[0]), float(q[1]), float(q[2]), float(q[3]), float(q[4]), float(q[5]),
                  float(np.sqrt(np.mean(sol.fun ** 2))), std)


# ---------------------------------------------------------------------------------------------
# Writing fixtures.


def write_csv(path: Path, rec: Recording, meta: dict[str, str], fmt: tuple[str, str, str]) -> None:
    lines = [f"# {key}: {value}" for key, value in meta.items()]
    lines.append("t,pressure_kpa,angle_deg")
    ft, fp, fa = fmt
    lines.extend(f"{t:{ft}},{p:{fp}},{a:{fa}}" for t, p, a in zip(rec.t, rec.p, rec.theta_deg, strict=True))
    path.write_text("\n".join(lines) + "\n")


def read_csv(path: Path) -> Recording:
    lines = [line for line in path.read_text().splitlines()
             if line.strip() and not line.lstrip().startswith("#")]
    header = lines[0].split(",")
    values = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    return Recording(values[:, header.index("t")], values[:, header.index("pressure_kpa")],
                     values[:, header.index("angle_deg")])


def write_model(path: Path, model: dict[str, float], comments: list[str]) -> None:
    lines = [f"# {c}" for c in comments]
    lines.extend(f"{key}: {value:.6g}" for key, value in model.items())
    path.write_text("\n".join(lines) + "\n")


def fit_summary(fit: OdeFit, inertia: float) -> dict[str, object]:
    out: dict[str, object] = {"model": fit.model(inertia), "rmse_deg": fit.rmse_deg}
    out["normalised"] = {k: v for k, v in asdict(fit).items() if k not in ("std",)}
    out["normalised_std"] = fit.std
    return out
