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

The linearised form holds while the smooth torques are a small part of the finger's own
stiffness. Where their slope over the recorded range reaches LINEAR_SLOPE_SHARE of k (a
stiff object met at 45° made an outside generator's finger look 15 times stiffer past it,
and gravity was fitted at that size), the linear finger is not the finger, and the onset
is fitted in full instead: the simulated finger with an object past θc (a spring, linear
in the depth: the simulator's own contact) in place of the smooth torques, k, B, N, θc and
the object's stiffness refitted, against the named model as fitted.

Both comparisons run on the innovations, where the noise model and the slow drift take what
neither model follows. Where the named model already follows the raw angle to the sensor's
noise (simulated from the recorded command, a constant offset alone: raw_error.py, within
raw_error.TIE_NOISE times the noise the fit estimates, the engine's tie at the noise), the
raw angle leaves nothing beyond the innovations' own size for an onset to
explain, and a gain on the innovations alone is no evidence that a torque switches on: the
onset is then fitted in full and must also follow the raw angle better than the named model,
by more than the raw angle's tie (raw_error.TIE_SHARE: within it, the two follow it equally).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal

from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import Fit, sensitivity
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.outside_library.rival_fit import Rival, rival_model
from hand_service.diagnose.residual import noise, stats
from hand_service.diagnose.workers import ordered_map
from rtcore.sim import SimFinger

SIGNIFICANT_BIC = 10.0
# the library's torques that are a function of the angle alone and smooth over it
SMOOTH_STATIC = ("cubic_stiffness", "gravity")
ONSET_QUANTILES = (0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.98, 0.99)
POWERS = (1.0, 1.5, 2.0)
EXTRA_PARAMS = 2  # θc and p: the onset's size stands for the smooth torque it replaces
# past this share of k, the smooth torques' slope makes the linear finger the wrong finger
LINEAR_SLOPE_SHARE = 0.5
FITTED_QUANTILES = (0.6, 0.8, 0.95)  # θc's starts for the onset fitted in full


@dataclass(frozen=True)
class Onset:
    angle_deg: float  # where the torque switches on
    power: float
    closing: bool  # True: past θc as the finger bends (an object, a stop); False: below it
    share_past: float  # of the fitting samples beyond θc
    delta_bic: float  # the onset torque against the smooth library torques
    fitted: bool = False  # both fitted in full (LINEAR_SLOPE_SHARE), else both linearised

    def to_json(self) -> dict:
        return {"angle_deg": self.angle_deg, "power": self.power,
                "side": "above" if self.closing else "below", "share_past": self.share_past,
                "delta_bic": self.delta_bic, "compared": "fitted" if self.fitted else "linearised"}

    @property
    def compared(self) -> str:
        return "both fitted in full" if self.fitted else "both linearised"

    def sentence(self, names: list[str]) -> str:
        side = "above" if self.closing else "below"
        return (f"the missing torque switches on {side} {self.angle_deg:.1f}° ({100 * self.share_past:.0f} % "
                f"of the samples) and is zero on the other side, as a contact or an end stop makes it "
                f"(∝ |θ − θc|^{self.power:g}): it explains the residual better than {' and '.join(names)} "
                f"(ΔBIC {self.delta_bic:.0f}, {self.compared}), which only approximate"
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


def library_slope(name: str, theta_rad: np.ndarray) -> np.ndarray:
    """d library_torque / dθ."""
    if name == "cubic_stiffness":
        return 3.0 * theta_rad**2
    if name == "gravity":
        return -np.sin(theta_rad)
    raise KeyError(name)


def smooth_slope_share(problem: Problem, final: Fit, smooth: list[str]) -> float:
    """The largest slope of the smooth torques over the fitted angles (each torque's size
    added: a bound on their sum's), as a share of the fitted k."""
    theta = np.radians(final.angle_deg[problem.fit_mask])
    theta = np.concatenate((theta, [np.pi / 2] if theta.min() < np.pi / 2 < theta.max() else []))
    slope = sum(np.abs(final.value(name) * library_slope(name, theta)) for name in smooth)
    return float(np.max(slope)) / final.value("stiffness_nm_per_rad")


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


def linearisation_error(problem: Problem, final: Fit, smooth: list[str],
                        columns: tuple[list[np.ndarray], np.ndarray, np.ndarray]) -> float:
    """How far the linear finger's columns miss the named model's own smooth torques: the
    angle they add in the simulated finger (with them against without), after the AR
    filter `a`, least-squares fitted by the smooth columns (`smooth_w`, filtered) beside
    the `shared` ones; the residual sum of squares over the fitting samples."""
    shared, smooth_w, a = columns
    mask = problem.fit_mask
    detrend = problem.noise.detrend
    own = detrend(final.angle_deg - problem.simulate(final.without(problem, smooth)))
    projection = Projection(through(np.column_stack(shared), a)[mask] if shared else None,
                            through(own, a)[mask])
    return projection.rss(smooth_w)


def raw_deg(problem: Problem, angle_deg: np.ndarray) -> float:
    """A model's RMS error on the raw angle, with its own constant offset (raw_error.py),
    over the fitting and held-out samples."""
    return raw_error.raw_rms_deg(problem, angle_deg, problem.fit_mask, problem.fit_mask | problem.held_mask)


def named_at_noise(problem: Problem, final: Fit) -> float | None:
    """The named model's raw RMS error where it follows the raw angle to the sensor's noise
    (within raw_error.TIE_NOISE times the fit's noise estimate, as the engine's tie at the
    noise), else None."""
    named_deg = raw_deg(problem, final.angle_deg)
    return named_deg if raw_error.at_noise(named_deg, final.sigma_deg) else None


def onset_check(problem: Problem, final: Fit, found: list[str]) -> Onset | None:
    """The onset family against the smooth static torques in `found` (SMOOTH_STATIC); the
    best onset when it wins by more than SIGNIFICANT_BIC (and, where the named model is at
    the noise on the raw angle, follows the raw angle better), else None."""
    smooth = [n for n in found if n in SMOOTH_STATIC]
    if not smooth:
        return None
    named_raw_deg = named_at_noise(problem, final)
    if named_raw_deg is not None or smooth_slope_share(problem, final, smooth) >= LINEAR_SLOPE_SHARE:
        return fitted_onset(problem, final, smooth, named_raw_deg)
    mask = problem.fit_mask
    theta_deg = final.angle_deg
    theta = np.radians(theta_deg)
    detrend = problem.noise.detrend
    # what both models share: k, B, N and the found effects that are not smooth static torques
    shared = [detrend(sensitivity(problem, p, final.finger, final.angle_deg)) for p in final.params
              if p.label not in smooth]
    # the final model without its smooth static torques: what they, or an onset, must explain
    target = problem.misfit(problem.simulate(final.without(problem, smooth)))
    linear = linear_finger(problem, final)
    smooth_cols = np.column_stack([detrend(linear.response_deg(library_torque(n, theta))) for n in smooth])
    # the noise's AR filter, from the smooth model's residual (the incumbent's: conservative)
    fitted, a = incumbent_projection(problem, shared, smooth_cols, target)
    smooth_w = through(smooth_cols, a)[mask]
    rss_smooth = fitted.rss(smooth_w)
    # Below LINEAR_SLOPE_SHARE the linear finger still misses the named torques' own
    # response by second-order terms: where that miss alone is worth SIGNIFICANT_BIC on the
    # residual compared, it could decide the comparison, and the onset is fitted in full.
    miss = linearisation_error(problem, final, smooth, (shared, smooth_w, a))
    if stats.delta_bic(rss_smooth + miss, rss_smooth, int(mask.sum()), 0) > SIGNIFICANT_BIC:
        return fitted_onset(problem, final, smooth)
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


def object_finger(finger: SimFinger, angle_deg: float, stiffness_nm_per_rad: float) -> SimFinger:
    """`finger` with the simulator's object met past `angle_deg` as it bends, its torque
    stiffness_nm_per_rad·(θ − θc) (a lever arm of 1 m makes the simulator's N/m the
    torque's N·m/rad)."""
    return dataclasses.replace(finger, prbm=dataclasses.replace(finger.prbm, lever_arm_m=1.0),
                               contact_angle_deg=angle_deg, contact_stiffness_n_per_m=stiffness_nm_per_rad,
                               contact_damping_ns_per_m=0.0)


def fitted_onset(problem: Problem, final: Fit, smooth: list[str],
                 named_raw_deg: float | None = None) -> Onset | None:
    """The onset fitted in full: `final` with an object met past θc in place of its smooth
    torques (its other effects held as fitted), k, B, N, θc and the object's stiffness
    refitted by output error from θc at FITTED_QUANTILES of the simulated angle (θc kept
    within its 0.5 % to 99.5 % quantiles: an object never or always touched is no onset),
    against `final` on the innovations. k, B and N are held by the same prior as `final`
    was (the engine's, or the nominal's where the effect's fit needed it), and the gain is
    the data's alone: the prior decides nothing here. The best object when it wins by
    more than SIGNIFICANT_BIC, and, where `named_raw_deg` is given (the named model at the
    noise on the raw angle), with a raw RMS error lower than that by more than
    raw_error.TIE_SHARE (within it the raw angle cannot choose); else None."""
    mask = problem.fit_mask
    k = final.value("stiffness_nm_per_rad")
    valid = final.angle_deg[mask]  # the simulator's frame, θc's (the sensor's offset and drift out)
    low_deg, high_deg = (float(q) for q in np.quantile(valid, (0.005, 0.995)))
    span_deg = max(high_deg - low_deg, 1e-9)

    def one(angle0_deg: float) -> tuple[Rival, float]:
        """The object fitted from θc = angle0_deg (θc's move over the angle's range, K over
        k), and its θc."""
        lower = np.array([(low_deg - angle0_deg) / span_deg, 1e-4])
        upper = np.array([(high_deg - angle0_deg) / span_deg, 1e3])
        rival = rival_model(problem, final, smooth, np.array([0.0, 1.0]), lower, upper,
                            lambda f, x: object_finger(f, angle0_deg + x[0] * span_deg, x[1] * k))
        return rival, angle0_deg + float(rival.extra[0]) * span_deg

    starts = [float(np.quantile(valid, q)) for q in FITTED_QUANTILES]
    rival, angle_c = min(ordered_map(one, starts), key=lambda fitted: fitted[0].rss)  # each start its own fit
    # θc and K against the smooth torques' own parameters: one more against one, none against two
    gain = stats.delta_bic(problem.fit_rss(problem.innovations(final.angle_deg)), rival.rss, problem.n_fit,
                           2 - len(smooth))
    if not gain > SIGNIFICANT_BIC:
        return None
    closer = named_raw_deg is None or \
        raw_deg(problem, rival.angle_deg) < (1.0 - raw_error.TIE_SHARE) * named_raw_deg
    if not closer:
        return None  # the named model is at the noise on the raw angle, the object ties with it
    return Onset(angle_c, 1.0, True, float(np.mean(valid > angle_c)), gain, fitted=True)
