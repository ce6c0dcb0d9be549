"""The plain linear PRBM, A·θ'' + B·θ' + k·θ = N·p, discretised exactly under a command held
between samples (zero-order hold), with an optional known valve (first-order lag, dead time
of any fraction of a period), and its output-error refit over k, B and N (A held).

The refit measures concealment: an effect is concealed at strength s when the best plain
model, refitted to the truth's noise-free angle at s, leaves a residual RMS of 0.4–1.5 ×
the sensor's noise RMS."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import signal
from scipy.linalg import expm

DEG = math.pi / 180.0


@dataclass(frozen=True)
class LinearModel:
    inertia_kgm2: float
    damping_nms_per_rad: float
    stiffness_nm_per_rad: float
    gain_nm_per_kpa: float
    valve_tau_s: float = 0.0
    delay_s: float = 0.0


def _phi_gamma(ac: np.ndarray, bc: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    n = ac.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = ac
    m[:n, n] = bc
    e = expm(m * tau)
    return e[:n, :n], e[:n, n]


def discrete_tf(model: LinearModel, rate_hz: float) -> tuple[np.ndarray, np.ndarray, int]:
    """(num, den, m): angle (rad) from the command held between samples and delayed by m whole
    samples; the fraction of a sample is in num."""
    a, b, k, g = (
        model.inertia_kgm2,
        model.damping_nms_per_rad,
        model.stiffness_nm_per_rad,
        model.gain_nm_per_kpa,
    )
    if model.valve_tau_s > 0:
        tv = model.valve_tau_s
        ac = np.array([[0.0, 1.0, 0.0], [-k / a, -b / a, g / a], [0.0, 0.0, -1.0 / tv]])
        bc = np.array([0.0, 0.0, 1.0 / tv])
    else:
        ac = np.array([[0.0, 1.0], [-k / a, -b / a]])
        bc = np.array([0.0, g / a])
    period = 1.0 / rate_hz
    whole = math.floor(model.delay_s * rate_hz + 1e-9)
    frac = model.delay_s * rate_hz - whole
    phi, gamma_b = _phi_gamma(ac, bc, (1.0 - frac) * period)
    phi_full, _ = _phi_gamma(ac, bc, period)
    if frac > 1e-9:
        _, gf = _phi_gamma(ac, bc, frac * period)
        gamma_a = phi @ gf
    else:
        gamma_a = np.zeros_like(gamma_b)
    ns = ac.shape[0]
    # state [x; u_prev], input v[n] = u[n − m]
    ad = np.zeros((ns + 1, ns + 1))
    ad[:ns, :ns] = phi_full
    ad[:ns, ns] = gamma_a
    bd = np.zeros((ns + 1, 1))
    bd[:ns, 0] = gamma_b
    bd[ns, 0] = 1.0
    c = np.zeros((1, ns + 1))
    c[0, 0] = 1.0
    num, den = signal.ss2tf(ad, bd, c, np.zeros((1, 1)))
    return np.asarray(num[0]), np.asarray(den), whole


def _parts(
    model: LinearModel, command_kpa: np.ndarray, rate_hz: float, theta0_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) with the angle (rad) = N·a + b: the response is linear in the gain."""
    u = np.asarray(command_kpa, dtype=float)
    u0 = u[0]
    unit = LinearModel(
        model.inertia_kgm2,
        model.damping_nms_per_rad,
        model.stiffness_nm_per_rad,
        1.0,
        model.valve_tau_s,
        model.delay_s,
    )
    num, den, m = discrete_tf(unit, rate_hz)
    v = np.concatenate([np.full(m, u0), u[: u.size - m]]) if m > 0 else u
    k = model.stiffness_nm_per_rad
    a = u0 / k + signal.lfilter(num, den, v - u0)
    th0 = theta0_deg * DEG
    b = np.zeros(u.size)
    if th0 != 0.0 or u0 != 0.0:
        # let go from th0 at rest: the mechanical part's free response toward the equilibrium
        # of the first command, N·u0/k; the deviation th0 − N·u0/k is linear in N
        if model.valve_tau_s > 0 or model.delay_s > 0:
            mech = LinearModel(model.inertia_kgm2, model.damping_nms_per_rad, k, 1.0)
            num, den, _ = discrete_tf(mech, rate_hz)
        step = 1.0 + signal.lfilter(num, den, np.full(u.size, -k))  # free response of a unit deviation
        b = th0 * step
        a = a - (u0 / k) * step
    return a, b


def response_deg(
    model: LinearModel, command_kpa: np.ndarray, rate_hz: float, theta0_deg: float = 0.0
) -> np.ndarray:
    """The angle at every sample: at rest at theta0_deg at t = 0 (held there if that is not the
    equilibrium of the first command), the chamber at the first command."""
    a, b = _parts(model, command_kpa, rate_hz, theta0_deg)
    return (model.gain_nm_per_kpa * a + b) / DEG


@dataclass(frozen=True)
class Refit:
    model: LinearModel
    residual_rms_deg: float
    residual_deg: np.ndarray


def refit(
    angle_deg: np.ndarray,
    command_kpa: np.ndarray,
    rate_hz: float,
    start: LinearModel,
    theta0_deg: float = 0.0,
) -> Refit:
    """Output-error least squares over k, B and N (A and the valve held): k and B by
    Levenberg-Marquardt on their logarithms from `start` (and from k × 0.9 and × 1.1 when the
    first fit leaves more than a tenth of a degree), N solved linearly at each step (the angle
    is linear in N); N is held when the command never changes.

    Written with einsum rather than BLAS calls: on a busy two-core machine a threaded BLAS
    spins and makes a 0.1 s refit take seconds."""
    y = np.asarray(angle_deg, dtype=float) * DEG
    u = np.asarray(command_kpa, dtype=float)
    fit_gain = bool(np.ptp(u) > 0.0)

    def solve(x: np.ndarray) -> tuple[np.ndarray, LinearModel]:
        trial = LinearModel(
            start.inertia_kgm2,
            start.damping_nms_per_rad * math.exp(x[1]),
            start.stiffness_nm_per_rad * math.exp(x[0]),
            start.gain_nm_per_kpa,
            start.valve_tau_s,
            start.delay_s,
        )
        a, b = _parts(trial, u, rate_hz, theta0_deg)
        g = start.gain_nm_per_kpa
        if fit_gain:
            aa = float(np.einsum("i,i->", a, a))
            if aa > 0:
                g = max(float(np.einsum("i,i->", a, y - b)) / aa, 1e-12)
        return (g * a + b - y) / DEG, replace(trial, gain_nm_per_kpa=g)

    best_x, best_cost = None, math.inf
    for k_factor in (1.0, 0.9, 1.1):
        x, cost = _levenberg_marquardt(lambda v: solve(v)[0], np.array([math.log(k_factor), 0.0]))
        if cost < best_cost:
            best_x, best_cost = x, cost
        if math.sqrt(best_cost / y.size) < 0.1:
            break
    assert best_x is not None
    r, model = solve(best_x)
    return Refit(model, float(np.sqrt(np.mean(r * r))), r)


def _levenberg_marquardt(
    fun, x0: np.ndarray, iterations: int = 60, step: float = 1e-6
) -> tuple[np.ndarray, float]:
    """Minimises ‖fun(x)‖² over a few parameters (forward-difference Jacobian)."""
    x = np.array(x0, dtype=float)
    r = fun(x)
    cost = float(np.einsum("i,i->", r, r))
    lam = 1e-3
    for _ in range(iterations):
        jac = np.empty((r.size, x.size))
        for j in range(x.size):
            dx = np.zeros_like(x)
            dx[j] = step
            jac[:, j] = (fun(x + dx) - r) / step
        jtj = np.einsum("ij,ik->jk", jac, jac)
        grad = np.einsum("ij,i->j", jac, r)
        improved = False
        for _ in range(12):
            lhs = jtj + lam * np.diag(np.diag(jtj) + 1e-12)
            delta = -np.linalg.solve(lhs, grad)
            delta = np.clip(delta, -1.0, 1.0)
            trial = np.clip(x + delta, -5.0, 5.0)
            rt = fun(trial)
            ct = float(np.einsum("i,i->", rt, rt))
            if ct < cost:
                converged = cost - ct < 1e-10 * cost + 1e-300
                x, r, cost = trial, rt, ct
                lam = max(lam / 5.0, 1e-9)
                improved = True
                break
            lam *= 8.0
        if not improved or converged or float(np.max(np.abs(delta))) < 1e-7:
            break
    return x, cost
