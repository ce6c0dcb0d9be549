"""A stiffening that switches on at an angle: a contact or an end stop, not a library spring.

A finger that meets an object, or its own end stop, feels no extra torque until the
contact angle θc and a steep one past it (Hertz: ∝ (θ − θc)^1.5). Over the samples past
θc a cubic spring or a gravity load can imitate that torque, and be named for it. Before
either is named, its torque is tested against the onset family

    τ = K·(θ − θc)^p  for θ > θc  (or K·(θc − θ)^p below θc: a stop when opening),
    θc at quantiles of the recorded angle, p ∈ {1, 1.5, 2},

in the same linearised form: each torque's response through the refitted finger's own
linear dynamics (J·δ'' + B·δ' + k·δ = −τ(θ(t)), the input held between samples, exact
for any stiffness), regressed with k, B, N and the other found effects on the
prewhitened residual. When the onset family explains the residual better by more than its
two extra parameters (θc, p) and SIGNIFICANT_BIC, the library's smooth torque was only
approximating a torque that starts at θc: the answer is "outside the library", with θc.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

from hand_service.config import effects as fx
from hand_service.diagnose import noise, stats
from hand_service.diagnose.fit import Fit, sensitivity
from hand_service.diagnose.problem import Problem

SIGNIFICANT_BIC = 10.0
# the library's torques that are a function of the angle alone and smooth over it
SMOOTH_STATIC = ("cubic_stiffness", "gravity")
ONSET_QUANTILES = (0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.98, 0.99)
POWERS = (1.0, 1.5, 2.0)
EXTRA_PARAMS = 2  # θc and p: the onset's size stands for the smooth torque it replaces


@dataclass(frozen=True)
class Onset:
    angle_deg: float  # where the torque switches on
    power: float
    closing: bool  # True: past θc as the finger bends (an object, a stop); False: below it
    share_past: float  # of the fitting samples beyond θc
    delta_bic: float  # the onset torque against the smooth library torques, both linearised

    def to_json(self) -> dict:
        return {"angle_deg": self.angle_deg, "power": self.power,
                "side": "above" if self.closing else "below", "share_past": self.share_past,
                "delta_bic": self.delta_bic}

    def sentence(self, names: list[str]) -> str:
        side = "above" if self.closing else "below"
        return (f"the missing torque switches on {side} {self.angle_deg:.1f}° ({100 * self.share_past:.0f} % "
                f"of the samples) and is zero on the other side, as a contact or an end stop makes it "
                f"(∝ |θ − θc|^{self.power:g}): it explains the residual better than {' and '.join(names)} "
                f"(ΔBIC {self.delta_bic:.0f}, both linearised), which only approximate"
                f"{'s' if len(names) == 1 else ''} it over the range; "
                "this is outside the library")


@dataclass(frozen=True)
class LinearFinger:
    """The finger's linear dynamics at a fit's k and B as a difference equation: the angle's
    response to an extra torque held between samples (exact for any stiffness or damping)."""

    num: np.ndarray
    den: np.ndarray

    def response_deg(self, torque_nm: np.ndarray) -> np.ndarray:
        return np.degrees(signal.lfilter(self.num, self.den, torque_nm))


def linear_finger(problem: Problem, final: Fit) -> LinearFinger:
    """J·δ'' + B·δ' + k·δ = −τ at `final`'s k and B, discretised with the input held."""
    inertia = float(problem.base.prbm.inertia_kgm2)
    k = final.value("stiffness_nm_per_rad")
    b = final.value("damping_nms_per_rad")
    dt_s = 1.0 / problem.rate_hz
    augmented = np.zeros((3, 3))
    augmented[0, 1] = 1.0
    augmented[1, 0], augmented[1, 1], augmented[1, 2] = -k / inertia, -b / inertia, -1.0 / inertia
    step = linalg.expm(augmented * dt_s)
    ad, bd = step[:2, :2], step[:2, 2]
    # x[n+1] = Ad x[n] + Bd u[n], y = x0: as a difference equation (2nd order, lfilter's C loop)
    num, den = signal.ss2tf(ad, bd.reshape(2, 1), np.array([[1.0, 0.0]]), np.zeros((1, 1)))
    return LinearFinger(np.asarray(num[0]), np.asarray(den))


def library_torque(name: str, theta_rad: np.ndarray) -> np.ndarray:
    """The library's torque per unit of its parameter (docs/formats.md, effects)."""
    if name == "cubic_stiffness":
        return theta_rad**3
    if name == "gravity":
        return -(1.0 - np.cos(theta_rad))
    raise KeyError(name)


class Projection:
    """Least squares on the columns shared by every model, done once: what a further column
    adds is then one projection (the fitting samples, after the AR filter)."""

    def __init__(self, shared: np.ndarray | None, target: np.ndarray) -> None:
        self.q = None if shared is None else np.linalg.qr(shared)[0]
        self.target = self.residual(target)

    def residual(self, x: np.ndarray) -> np.ndarray:
        return x if self.q is None else x - self.q @ (self.q.T @ x)

    def rss(self, columns: np.ndarray) -> float:
        """The target's residual sum of squares with `columns` (n × m) added."""
        c = self.residual(columns)
        coef, *_ = np.linalg.lstsq(c, self.target, rcond=None)
        e = self.target - c @ coef
        return float(e @ e)


def through(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """x through the AR filter a (the innovations' filter), along its first axis."""
    return signal.lfilter(np.concatenate(([1.0], -a)), [1.0], x, axis=0) if a.size else x


def incumbent_projection(problem: Problem, shared: list[np.ndarray], incumbent: np.ndarray,
                         target: np.ndarray) -> tuple[Projection, np.ndarray]:
    """The AR filter of the incumbent model's residual (the shared columns and the incumbent's
    own, fitted linearly to `target`: conservative), and the projection of the filtered
    target on the filtered shared columns, over the fitting samples."""
    mask = problem.fit_mask
    design = np.column_stack([*shared, incumbent])
    coef, *_ = np.linalg.lstsq(design[mask], target[mask], rcond=None)
    order = problem.noise.order
    a = noise.yule_walker(target[mask] - design[mask] @ coef, order)[0] if order else np.zeros(0)
    fitted = Projection(through(np.column_stack(shared), a)[mask] if shared else None,
                        through(target, a)[mask])
    return fitted, a


def onset_check(problem: Problem, final: Fit, found: list[str]) -> Onset | None:
    """The onset family against the smooth static torques in `found` (SMOOTH_STATIC); the
    best onset when it wins by more than SIGNIFICANT_BIC, else None."""
    smooth = [n for n in found if n in SMOOTH_STATIC]
    if not smooth:
        return None
    mask = problem.fit_mask
    theta_deg = final.angle_deg
    theta = np.radians(theta_deg)
    detrend = problem.noise.detrend
    # what both models share: k, B, N and the found effects that are not smooth static torques
    shared = [detrend(sensitivity(problem, p, final.finger, final.angle_deg)) for p in final.params
              if p.label not in smooth]
    # the final model without its smooth static torques: what they, or an onset, must explain
    params = [p for p in final.params if p.label in smooth]
    without = problem.finger(params, [fx.BY_NAME[p.label].neutral for p in params], final.finger)
    target = problem.misfit(problem.simulate(without))
    linear = linear_finger(problem, final)
    smooth_cols = np.column_stack([detrend(linear.response_deg(library_torque(n, theta))) for n in smooth])
    # the noise's AR filter, from the smooth model's residual (the incumbent's: conservative)
    fitted, a = incumbent_projection(problem, shared, smooth_cols, target)
    smooth_w = through(smooth_cols, a)[mask]
    rss_smooth = fitted.rss(smooth_w)
    # the onset in place of one smooth torque, the others kept (a gravity load and a contact
    # can both be there)
    kept = [np.delete(smooth_w, i, axis=1) for i in range(len(smooth))]
    valid = theta_deg[mask]
    best: Onset | None = None
    best_rss = np.inf
    for closing in (True, False):
        for q in ONSET_QUANTILES:
            angle_c = float(np.quantile(valid, q if closing else 1.0 - q))
            depth = np.maximum(theta - np.radians(angle_c), 0.0) if closing else \
                np.maximum(np.radians(angle_c) - theta, 0.0)
            for power in POWERS:
                col = through(detrend(linear.response_deg(depth**power)), a)[mask][:, None]
                rss = min(fitted.rss(np.column_stack((others, col))) for others in kept)
                if rss < best_rss:
                    share = float(np.mean(valid > angle_c) if closing else np.mean(valid < angle_c))
                    best_rss, best = rss, Onset(angle_c, power, closing, share, 0.0)
    if best is None or best_rss <= 0.0:
        return None
    gain = stats.delta_bic(rss_smooth, best_rss, int(mask.sum()), EXTRA_PARAMS)
    if gain <= SIGNIFICANT_BIC:
        return None
    return Onset(best.angle_deg, best.power, best.closing, best.share_past, gain)
