"""Truth fingers and their integrator, written apart from the project's simulator.

The finger obeys

    A·θ'' + B·θ' + k·θ + τ_x(θ, θ', z) + F_f = N·p_eff

with θ in rad, p in kPa. Every extra torque has a physical form that differs from the
library's (docs/formats.md §2.1), on purpose:

| truth | form here | library's form |
|---|---|---|
| dry friction | Karnopp: θ' = 0 while net torque < T_s = 1.3·T_k; slips at T_k+Stribeck | T_c·tanh(θ'/ω_s) |
| gravity | G·[cos(θ + φ0) − cos φ0]: the weight's torque with a mounting angle φ0 | −G·(1 − cos θ) |
| spring | k·θ·(1 + (θ/θs)²)^0.75, k·θs·sinh(θ/θs) (stiffening) or k·θs·tanh(θ/θs) (softening) | k·θ + k3·θ³ |
| drag | c2·|θ'|·θ' + c2·ω_k·θ' (air drag with a small linear part) | c2·|θ'|·θ' |
| valve | first-order lag τ whose slope is rate limited to 0.6·p_fs/τ | first-order lag |
| dead time | the command seen `delay` later | same |
| dead zone | soft knee: w·ln(1 + e^((p−p0)/w)), zero at p = 0, w = 0.2·p0 | max(p − p0, 0) |
| asymmetric spring | k·θ·[1 + (ρ − 1)·σ(−θ/w)], a logistic over about 1.5° | k or ρ·k by the sign of θ |
| hysteresis (not in the library) | Bouc-Wen: K_h·z, ż = θ' − β·|θ'|·z − γ·θ'·|z|, β = γ = 1/(2·z_max) | — |
| contact (not in the library) | Hunt-Crossley K_c·δ^1.5·(1 + λ·δ'), δ = θ − θ_c > 0 | — |
| pressure stiffening | k·s·g(p_eff/p_fs)·θ, g = x^0.7 or (e^x − 1)/(e − 1) (odd seeds) | k·c·(p/p_ref)·θ |
| creep | two Maxwell branches, β/2·k each, time constants T and 4·T (a Prony series) | one branch β·k, T |
| pressure damping (no library form) | B·r·(p_eff/p_fs)·θ', growing with the pressure | — |

The integrator: the linear part (A, B, k) is propagated exactly over a fixed sub-step
(matrix exponential, so the stiff over-damped family is no trouble), the extra torques are
held over the sub-step (at most 0.25 ms), the command is held between samples (zero-order
hold) and the angle is taken at the sample instants: angle[i + 1] follows command[i].
Dry friction is integrated as Karnopp's model: in the stuck state θ' is exactly 0; the finger
breaks away when the net torque passes T_s, and sticks again when its velocity crosses zero
while the net torque is under T_s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import expm

DEG = math.pi / 180.0


@dataclass(frozen=True)
class Family:
    """One kind of finger: the plain PRBM's A, B, k, N and a full-scale pressure that bends it
    to about 80°."""

    name: str
    inertia_kgm2: float
    damping_nms_per_rad: float
    stiffness_nm_per_rad: float
    gain_nm_per_kpa: float
    full_scale_kpa: float
    pressure_cap_kpa: float = 150.0

    @property
    def natural_hz(self) -> float:
        return math.sqrt(self.stiffness_nm_per_rad / self.inertia_kgm2) / (2.0 * math.pi)

    @property
    def damping_ratio(self) -> float:
        return self.damping_nms_per_rad / (2.0 * math.sqrt(self.stiffness_nm_per_rad * self.inertia_kgm2))

    @property
    def corner_hz(self) -> float:
        """Where the finger stops following the pressure quasi-statically: its resonance when
        it rings, its slow pole k/B when it is over-damped."""
        if self.damping_ratio < 1.0:
            return self.natural_hz
        a, b, k = self.inertia_kgm2, self.damping_nms_per_rad, self.stiffness_nm_per_rad
        slow = (b - math.sqrt(b * b - 4.0 * a * k)) / (2.0 * a)
        return slow / (2.0 * math.pi)

    @property
    def full_scale_deg(self) -> float:
        return self.gain_nm_per_kpa * self.full_scale_kpa / self.stiffness_nm_per_rad / DEG


FAMILIES: dict[str, Family] = {
    # (a) the paper's ringing finger: 9.5 Hz, damping ratio 0.16
    "ringing": Family("ringing", 1.6e-4, 0.003, 0.57, 0.0119, 67.0),
    # (b) an over-damped soft actuator: B/A = 5000 /s, slow pole k/B = 10 /s
    "overdamped": Family("overdamped", 1.0e-5, 0.05, 0.5, 0.01, 70.0),
    # (c) a stiffer rig of another scale: 8 Hz, damping ratio 0.25
    "stiff": Family("stiff", 2.0e-3, 0.05, 5.0, 0.1, 70.0),
}


@dataclass(frozen=True)
class Truth:
    """A finger with its extra physics; every extra is off at its default."""

    family: Family
    # Karnopp stick-slip friction
    friction_kinetic_nm: float = 0.0
    friction_static_ratio: float = 1.3
    stribeck_rad_s: float = 0.02
    # posture-dependent gravity
    gravity_nm: float = 0.0
    mount_deg: float = 0.0
    # spring: "linear", "power", "sinh" (stiffening) or "tanh" (softening); 1/θs² in rad⁻²
    spring_form: str = "linear"
    spring_inv_scale2: float = 0.0
    # drag
    drag_c2: float = 0.0
    drag_knee_rad_s: float = 1.0
    # valve
    valve_tau_s: float = 0.0
    valve_rate_kpa_s: float = math.inf
    delay_s: float = 0.0
    deadzone_kpa: float = 0.0
    deadzone_knee_kpa: float = 0.0
    # asymmetric stiffness: k·ratio for θ < 0, over a logistic of width w
    asym_ratio: float = 1.0
    asym_width_deg: float = 0.35
    # out of the library
    hysteresis_nm_per_rad: float = 0.0
    hysteresis_zmax_deg: float = 10.0
    contact_deg: float = math.inf
    contact_nm_per_rad15: float = 0.0
    contact_damping_s_per_rad: float = 0.3
    # pressure stiffening: k·s·(p_eff/p_fs)^0.7 ("power") or k·s·(e^(p_eff/p_fs) − 1)/(e − 1)
    # ("exp") added to k
    stiffening_s: float = 0.0
    stiffening_form: str = "power"
    # creep: two Maxwell branches beside k, (β/2)·k each, time constants T and 4·T
    creep_beta: float = 0.0
    creep_time_s: float = 1.0
    # pressure-dependent damping: B·r·(p_eff/p_fs) added to B (outside all the library's forms)
    pressure_damping_ratio: float = 0.0

    def with_(self, **changes: float | str) -> Truth:
        return replace(self, **changes)

    # -- the forms, one value at a time (used by the tests and the observability rules) --

    def spring_extra(self, theta: float) -> float:
        """The spring's torque beyond k·θ (N·m), including the asymmetry."""
        k = self.family.stiffness_nm_per_rad
        g = theta
        s = self.spring_inv_scale2
        if s > 0.0 and self.spring_form != "linear":
            ts = 1.0 / math.sqrt(s)
            if self.spring_form == "power":
                g = theta * (1.0 + theta * theta * s) ** 0.75
            elif self.spring_form == "sinh":
                g = ts * math.sinh(theta / ts)
            elif self.spring_form == "tanh":
                g = ts * math.tanh(theta / ts)
            else:
                raise ValueError(f"unknown spring form {self.spring_form!r}")
        if self.asym_ratio != 1.0:
            w = self.asym_width_deg * DEG
            x = -theta / w
            sig = 1.0 / (1.0 + math.exp(-x)) if x > -700 else 0.0
            g = g * (1.0 + (self.asym_ratio - 1.0) * sig)
        return k * (g - theta)

    def gravity_extra(self, theta: float) -> float:
        """Resisting torque of gravity relative to rest (N·m): −G·[cos(θ + φ0) − cos φ0]."""
        phi = self.mount_deg * DEG
        return -self.gravity_nm * (math.cos(theta + phi) - math.cos(phi))

    def effective_pressure(self, p: float) -> float:
        p0 = self.deadzone_kpa
        if p0 <= 0.0:
            return p
        w = self.deadzone_knee_kpa if self.deadzone_knee_kpa > 0 else 0.2 * p0
        return _softplus((p - p0) / w) * w - _softplus(-p0 / w) * w

    def static_torque(self, theta: float, pressure: float, z: float = 0.0) -> float:
        """Net torque on the still finger without friction: N·p_eff − k·θ − extras (N·m)."""
        f = self.family
        tau = f.gain_nm_per_kpa * self.effective_pressure(pressure) - f.stiffness_nm_per_rad * theta
        tau -= self.spring_extra(theta) + self.gravity_extra(theta) + self.hysteresis_nm_per_rad * z
        if self.contact_nm_per_rad15 > 0 and theta > self.contact_deg * DEG:
            tau -= self.contact_nm_per_rad15 * (theta - self.contact_deg * DEG) ** 1.5
        return tau


def _softplus(x: float) -> float:
    return x + math.log1p(math.exp(-x)) if x > 0 else math.log1p(math.exp(x))


@dataclass
class Trajectory:
    """The truth at the sample instants."""

    theta_deg: np.ndarray
    omega_rad_s: np.ndarray
    command_kpa: np.ndarray
    chamber_kpa: np.ndarray
    stuck: np.ndarray  # the friction's stuck state at the sample (bool)
    measured_deg: np.ndarray | None = None


Controller = Callable[[int, float], float]


def _linear_step(family: Family, h: float) -> tuple[float, ...]:
    """Exact propagation of the plain PRBM over h under a constant torque:
    x⁺ = Φ·x + Γ·torque."""
    a, b, k = family.inertia_kgm2, family.damping_nms_per_rad, family.stiffness_nm_per_rad
    m = np.zeros((3, 3))
    m[0, 1] = 1.0
    m[1, 0] = -k / a
    m[1, 1] = -b / a
    m[1, 2] = 1.0 / a
    e = expm(m * h)
    return e[0, 0], e[0, 1], e[1, 0], e[1, 1], e[0, 2], e[1, 2]


def simulate(
    truth: Truth,
    rate_hz: float,
    n: int,
    command: np.ndarray | None = None,
    controller: Controller | None = None,
    measure: Callable[[int, float], float] | None = None,
    theta0_deg: float = 0.0,
    substep_s: float = 2.5e-4,
) -> Trajectory:
    """Integrates the truth over n samples.

    Open loop: `command` (kPa, n values) is held from each sample to the next. Closed loop:
    `controller(i, measured_deg)` gives command i from the measurement at sample i, which
    `measure(i, true_deg)` makes (the sensor); the measurements are kept.
    The finger starts at rest at `theta0_deg` (held there, then let go at t = 0), the
    chamber at the first command, the command's history before t = 0 equal to its first
    value."""
    if (command is None) == (controller is None):
        raise ValueError("give a command or a controller")
    f = truth.family
    period = 1.0 / rate_hz
    sub = max(1, math.ceil(period / substep_s - 1e-9))
    h = period / sub
    p00, p01, p10, p11, g0, g1 = _linear_step(f, h)
    k, gain = f.stiffness_nm_per_rad, f.gain_nm_per_kpa

    # what is switched on
    fric = truth.friction_kinetic_nm > 0.0
    tk = truth.friction_kinetic_nm
    ts = tk * truth.friction_static_ratio
    vs = truth.stribeck_rad_s
    spring_on = (truth.spring_inv_scale2 > 0.0 and truth.spring_form != "linear") or truth.asym_ratio != 1.0
    grav = truth.gravity_nm != 0.0
    gnm, phi = truth.gravity_nm, truth.mount_deg * DEG
    cphi = math.cos(phi)
    drag = truth.drag_c2 > 0.0
    c2, c1 = truth.drag_c2, truth.drag_c2 * truth.drag_knee_rad_s
    tau_v = truth.valve_tau_s
    av = math.exp(-h / tau_v) if tau_v > 0 else 0.0
    lag_mean = tau_v / h * (1.0 - av) if tau_v > 0 else 0.0
    rate_step = truth.valve_rate_kpa_s * h
    delay = truth.delay_s
    dz = truth.deadzone_kpa > 0.0
    hyst = truth.hysteresis_nm_per_rad > 0.0
    kh = truth.hysteresis_nm_per_rad
    bw = 1.0 / (2.0 * truth.hysteresis_zmax_deg * DEG)
    contact = truth.contact_nm_per_rad15 > 0.0
    thc, kc, lam = truth.contact_deg * DEG, truth.contact_nm_per_rad15, truth.contact_damping_s_per_rad
    spring_extra, eff_p = truth.spring_extra, truth.effective_pressure
    stiffening = truth.stiffening_s > 0.0
    ks, p_fs = k * truth.stiffening_s, f.full_scale_kpa
    exp_form = truth.stiffening_form == "exp"
    creep = truth.creep_beta > 0.0
    b_per_kpa = f.damping_nms_per_rad * truth.pressure_damping_ratio / p_fs
    kb = 0.5 * truth.creep_beta * k
    creep_keep = (math.exp(-h / truth.creep_time_s), math.exp(-h / (4.0 * truth.creep_time_s)))

    theta = theta0_deg * DEG
    omega = 0.0
    z = 0.0
    creep_x = [theta, theta]  # the branches' dashpots, relaxed at the start
    stuck = fric
    cmd = np.zeros(n) if command is None else np.asarray(command, dtype=float)
    if command is not None and cmd.size != n:
        raise ValueError("command has the wrong length")
    measured = np.zeros(n) if controller is not None else None
    out_th, out_om = np.empty(n), np.empty(n)
    out_pc, out_st = np.empty(n), np.zeros(n, dtype=bool)

    if controller is not None:
        assert measure is not None
        measured[0] = measure(0, theta / DEG)
        cmd[0] = controller(0, measured[0])
    pc = float(cmd[0])
    for i in range(n):
        out_th[i], out_om[i], out_pc[i], out_st[i] = theta, omega, pc, stuck
        if i > 0 and controller is not None:
            measured[i] = measure(i, theta / DEG)
            cmd[i] = controller(i, measured[i])
        if i == n - 1:
            break
        t0 = i * period
        for s in range(sub):
            # the command the chamber sees: held between samples, `delay` later; over a
            # sub-step that a delayed switch cuts, the mean of the two values
            if delay > 0.0:
                ta = t0 + s * h - delay
                ja = math.floor(ta * rate_hz + 1e-9)
                jb = math.floor((ta + h) * rate_hz - 1e-9)
                ua = cmd[ja] if ja >= 0 else cmd[0]
                if jb == ja:
                    ud = ua
                else:
                    tc = jb / rate_hz
                    ud = (ua * (tc - ta) + (cmd[jb] if jb >= 0 else cmd[0]) * (ta + h - tc)) / h
            else:
                ud = cmd[i]
            if tau_v > 0.0:
                # the chamber's mean over the sub-step: exact for the lag, linear when rate-limited
                new = ud + (pc - ud) * av
                step = new - pc
                if step > rate_step:
                    new = pc + rate_step
                    pm = 0.5 * (pc + new)
                elif step < -rate_step:
                    new = pc - rate_step
                    pm = 0.5 * (pc + new)
                else:
                    pm = ud + (pc - ud) * lag_mean
                pc = new
            else:
                pc = pm = ud
            drive = gain * (eff_p(pm) if dz else pm)
            if stiffening:
                x = max(eff_p(pm) if dz else pm, 0.0) / p_fs
                drive -= ks * (math.expm1(x) / (math.e - 1.0) if exp_form else x**0.7) * theta
            if creep:
                drive -= kb * ((theta - creep_x[0]) + (theta - creep_x[1]))
            if spring_on:
                drive -= spring_extra(theta)
            if grav:
                drive += gnm * (math.cos(theta + phi) - cphi)
            if hyst:
                drive -= kh * z
            # velocity-proportional torques are taken implicitly (Picard): c·θ' at the
            # sub-step's end, c from its start, so strong drag cannot make the step unstable
            visc = 0.0
            if contact and theta > thc:
                d = theta - thc
                elastic = kc * d * math.sqrt(d)
                if elastic * (1.0 + lam * omega) > 0.0:
                    drive -= elastic
                    visc = elastic * lam
            if drag:
                visc += c2 * abs(omega) + c1
            if b_per_kpa > 0.0:
                visc += b_per_kpa * max(eff_p(pm) if dz else pm, 0.0)
            if fric:
                if stuck:
                    net = drive - k * theta
                    if abs(net) <= ts:
                        continue  # held by static friction: θ' = 0 exactly
                    stuck = False
                    fr = ts if net > 0 else -ts
                else:
                    mag = tk + (ts - tk) * math.exp(-((omega / vs) ** 2))
                    fr = mag if omega > 0 else -mag if omega < 0 else 0.0
                drive -= fr
            th_new = p00 * theta + p01 * omega + g0 * drive
            om_new = p10 * theta + p11 * omega + g1 * drive
            if visc > 0.0:
                om_new /= 1.0 + g1 * visc
                th_new -= g0 * visc * om_new
            if fric:
                if omega > 0.0:
                    crossed = om_new <= 0.0
                elif omega < 0.0:
                    crossed = om_new >= 0.0
                else:
                    crossed = om_new * fr <= 0.0
                if crossed and abs(drive + fr - k * th_new) <= ts:
                    # the velocity crossed zero and static friction holds the finger
                    stuck = True
                    om_new = 0.0
            if hyst:
                dth = th_new - theta
                z += dth - bw * abs(dth) * z - bw * dth * abs(z)
            if creep:  # each dashpot relaxes toward the angle at the sub-step's mean
                mean = 0.5 * (theta + th_new)
                creep_x = [mean + (x - mean) * keep for x, keep in zip(creep_x, creep_keep, strict=True)]
            theta, omega = th_new, om_new
    return Trajectory(out_th / DEG, out_om, cmd, out_pc, out_st, measured)


def equilibrium_deg(truth: Truth, pressure_kpa: float) -> float:
    """The angle where the spring, gravity and pressure balance (no friction, no hysteresis)."""
    lo, hi = -3.0, 3.0
    f_lo = truth.static_torque(lo, pressure_kpa)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f_mid = truth.static_torque(mid, pressure_kpa)
        if (f_mid > 0) == (f_lo > 0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi) / DEG
