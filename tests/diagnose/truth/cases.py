"""One battery case: a truth finger with one hidden effect (or none, or one outside the
library), a recording of one excitation through a lab's sensor, the lab's nominal model, and
what diagnose is expected to say.

**Concealment.** An effect's size is one scalar strength s (table below). Its visibility
v(s) is the RMS residual that the best plain linear model (k, B, N refitted by
`linear.refit` to the truth's noise-free angle, A and any known valve effect held) leaves,
over the sensor's noise RMS (`Sensor.noise_rms_deg`: white, correlated and ADC rounding;
offset and drift left out). `calibrate` solves v(s) = target in log-log (a secant while
the root is not bracketed, then regula falsi with a bisection when it stalls), to within
12 %, starting at a typical size and bounded by the effect's largest plausible size:
"concealed" draws its target in 0.5–1.3 (landing in 0.44–1.46), "evident" in 3–5.

**Observability.** A case is `unobservable` (diagnose should then name nothing wrong:
consistent, parameters_only, insufficient_excitation or the true name are accepted) when
the physics is not exercised by the recording:

| effect | exercised when |
|---|---|
| valve_lag, dead_time | the command changes and is not one slow sine (k, B, N absorb a lag) |
| pressure_deadzone | the command is above the threshold for 1 s or more |
| asymmetric_stiffness | the finger spends 0.1 s or more below −2° and 0.1 s above +2° |
| cubic_stiffness, gravity | the angle reaches 5° |
| quadratic_damping | the speed reaches 0.2 rad/s |
| coulomb_friction | always (every recording stops or reverses the finger) |

or when the effect, even at its largest plausible size, leaves v < 0.4 (the plain model
absorbs it); or when what the plain model, the sensor's offset and drift and, for gravity
and a cubic spring, the other of the two leave of it together is under 0.4 × the noise
(distinct.py: a finger that bends one way only cannot tell θ³ from 1 − cos θ unless the
effect is large; dry friction on a finger that moves one way only is an offset).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field, replace

import numpy as np

from tests.diagnose.truth import excitation as ex
from tests.diagnose.truth.calibration import calibrate
from tests.diagnose.truth.distinct import distinct_visibility
from tests.diagnose.truth.files import write as write  # cases.write: the case on disk
from tests.diagnose.truth.linear import LinearModel, refit
from tests.diagnose.truth.plant import DEG, FAMILIES, Family, Trajectory, Truth, simulate
from tests.diagnose.truth.sensor import Sensor

LIBRARY = (
    "valve_lag",
    "dead_time",
    "coulomb_friction",
    "cubic_stiffness",
    "gravity",
    "asymmetric_stiffness",
    "quadratic_damping",
    "pressure_deadzone",
)
# hysteresis and contact are in the library but searched only on request: outside the eight
# searched by default; pressure damping is in no library form
OUT_OF_LIBRARY = ("hysteresis", "contact", "pressure_damping")
CLEAN = "clean"
ALL_EFFECTS = (*LIBRARY, CLEAN, *OUT_OF_LIBRARY)
# library effects beyond the eight that on_request.py runs asked for by name (`--search`):
# diagnose searches the stiffening only so, creep behind the screen by default too
ON_REQUEST = ("pressure_stiffening", "creep")
# the order that rotates each effect's family and rate (CaseSpec.resolved): a later effect
# appended at its end moves no earlier case
ROTATION = (*LIBRARY, CLEAN, "hysteresis", "contact", *ON_REQUEST, "pressure_damping")
FAMILY_NAMES = ("ringing", "overdamped", "stiff")
RATES = (100.0, 200.0, 500.0, 1000.0)
TARGETS = {"concealed": (0.5, 1.3), "evident": (3.0, 5.0)}
ACCEPT = {"concealed": (0.4, 1.5), "evident": (2.5, 6.0)}


@dataclass(frozen=True)
class CaseSpec:
    effect: str
    excitation: str
    seed: int
    magnitude: str = "concealed"  # "concealed", "evident"; "none" for clean cases
    family: str | None = None  # None: by rotation
    rate_hz: float | None = None  # None: by rotation
    strength: float | None = None  # None: calibrated
    duration_s: float = 30.0  # the free release is 6 s whatever this says

    def resolved(self) -> CaseSpec:
        ie, ic = ROTATION.index(self.effect), ex.CLASSES.index(self.excitation)
        fam = self.family or FAMILY_NAMES[(self.seed + ic + ie) % 3]
        rate = self.rate_hz or RATES[(self.seed + 3 * ic + 2 * ie) % 4]
        mag = "none" if self.effect == CLEAN else self.magnitude
        return CaseSpec(
            self.effect, self.excitation, self.seed, mag, fam, rate, self.strength, self.duration_s
        )

    @property
    def id(self) -> str:
        r = self.resolved()
        tail = "" if r.duration_s == 30.0 else f"-{r.duration_s:g}s"
        return f"{r.effect}-{r.excitation}-s{r.seed}-{r.magnitude}-{r.family}-{int(r.rate_hz)}hz{tail}"


@dataclass
class Case:
    spec: CaseSpec
    truth: Truth
    nominal: LinearModel
    nominal_effects: dict[str, dict[str, float]]
    sensor: Sensor
    plan: ex.Plan
    trajectory: Trajectory
    measured_deg: np.ndarray
    strength: float
    visibility: float
    observable: bool
    reason: str
    library_equivalent: dict[str, float] = field(default_factory=dict)
    calibration: list[tuple[float, float]] = field(default_factory=list)

    @property
    def rate_hz(self) -> float:
        return self.plan.rate_hz

    def summary(self) -> dict:
        s = self.spec.resolved()
        return {
            "id": s.id,
            "effect": s.effect,
            "excitation": s.excitation,
            "seed": s.seed,
            "magnitude": s.magnitude,
            "family": s.family,
            "rate_hz": s.rate_hz,
            "duration_s": self.plan.n / self.plan.rate_hz,
            "strength": self.strength,
            "library_equivalent": self.library_equivalent,
            "visibility": self.visibility,
            "noise_rms_deg": self.sensor.noise_rms_deg,
            "observable": self.observable,
            "reason": self.reason,
            "nominal_effects": self.nominal_effects,
            "angle_range_deg": [
                float(self.trajectory.theta_deg.min()),
                float(self.trajectory.theta_deg.max()),
            ],
            "calibration": self.calibration,
        }


def _rng(spec: CaseSpec, stream: str) -> np.random.Generator:
    key = [
        spec.seed,
        zlib.crc32(spec.effect.encode()),
        zlib.crc32(spec.excitation.encode()),
        zlib.crc32(stream.encode()),
    ]
    return np.random.default_rng(key)


# -- the effects: strength → truth ------------------------------------------------------------


@dataclass(frozen=True)
class Shape:
    """What the seed fixes about an effect besides its strength."""

    sign: float = 1.0
    form: str = "power"
    mount_deg: float = 0.0
    static_ratio: float = 1.3
    known_delay_s: float = 0.0
    known_tau_s: float = 0.0
    width_deg: float = 0.35
    zmax_deg: float = 10.0
    contact_deg: float = 60.0
    creep_time_s: float = 0.5
    stiffening_form: str = "power"


def shape_of(spec: CaseSpec) -> Shape:
    rng = _rng(spec, "shape")
    odd = spec.seed % 2 == 1
    return Shape(
        sign=-1.0 if odd else 1.0,
        form=("power", "sinh", "tanh")[spec.seed % 3],
        mount_deg=float(rng.uniform(-25.0, 25.0)),
        static_ratio=float(rng.uniform(1.2, 1.4)),
        known_delay_s=float(rng.uniform(0.004, 0.012)),
        known_tau_s=float(rng.uniform(0.015, 0.04)),
        width_deg=float(rng.uniform(0.25, 0.5)),
        zmax_deg=float(rng.uniform(8.0, 15.0)),
        contact_deg=float(rng.uniform(0.75, 0.9)),
        creep_time_s=float(rng.uniform(0.3, 1.0)),
        stiffening_form="exp" if odd else "power",
    )  # contact: a quantile of the free angle


def bounds(effect: str, family: Family, shape: Shape, top_kpa: float) -> tuple[float, float, float]:
    """(typical, smallest, largest plausible) strength."""
    k, b = family.stiffness_nm_per_rad, family.damping_nms_per_rad
    omega_typ = 2.0 * math.pi * family.corner_hz * family.full_scale_deg * DEG * 0.3
    table = {
        "valve_lag": (0.01, 5e-5, 0.3),
        "dead_time": (0.005, 2e-5, 0.2),
        "coulomb_friction": (0.004 * k, 1e-5 * k, 0.15 * k),
        "cubic_stiffness": (0.1, 1e-3, 0.4 if shape.form == "tanh" else 6.0),
        "gravity": (0.03 * k, 1e-4 * k, 0.6 * k),
        "asymmetric_stiffness": (0.1, 0.003, math.log(4.0)),
        "quadratic_damping": (0.3 * b / omega_typ, 1e-3 * b / omega_typ, 30.0 * b / omega_typ),
        "pressure_deadzone": (0.03 * max(top_kpa, 1.0), 1e-3 * max(top_kpa, 1.0), 0.5 * max(top_kpa, 1.0)),
        "hysteresis": (0.05 * k, 1e-3 * k, 3.0 * k),
        "contact": (1.0 * k, 1e-3 * k, 100.0 * k),
        "pressure_stiffening": (0.3, 1e-3, 3.0),
        "creep": (0.1, 1e-3, 2.0),
        "pressure_damping": (1.0, 1e-3, 30.0),
    }
    return table[effect]


def truth_at(
    effect: str, s: float, family: Family, shape: Shape, top_kpa: float, contact_deg: float = math.inf
) -> Truth:
    base = Truth(family)
    if effect == "valve_lag":
        return base.with_(
            valve_tau_s=s,
            valve_rate_kpa_s=0.6 * max(top_kpa, 1.0) / s if s > 0 else math.inf,
            delay_s=shape.known_delay_s,
        )
    if effect == "dead_time":
        return base.with_(delay_s=s, valve_tau_s=shape.known_tau_s)
    if effect == "coulomb_friction":
        return base.with_(friction_kinetic_nm=s, friction_static_ratio=shape.static_ratio)
    if effect == "cubic_stiffness":
        return base.with_(spring_form=shape.form, spring_inv_scale2=s)
    if effect == "gravity":
        return base.with_(gravity_nm=shape.sign * s, mount_deg=shape.mount_deg)
    if effect == "asymmetric_stiffness":
        return base.with_(asym_ratio=math.exp(shape.sign * s), asym_width_deg=shape.width_deg)
    if effect == "quadratic_damping":
        return base.with_(drag_c2=s)
    if effect == "pressure_deadzone":
        return base.with_(deadzone_kpa=s)
    if effect == "hysteresis":
        return base.with_(hysteresis_nm_per_rad=s, hysteresis_zmax_deg=shape.zmax_deg)
    if effect == "contact":
        return base.with_(contact_deg=contact_deg, contact_nm_per_rad15=s)
    if effect == "pressure_stiffening":
        return base.with_(stiffening_s=s, stiffening_form=shape.stiffening_form)
    if effect == "creep":
        return base.with_(creep_beta=s, creep_time_s=shape.creep_time_s)
    if effect == "pressure_damping":
        return base.with_(pressure_damping_ratio=s)
    if effect == CLEAN:
        return base
    raise ValueError(f"unknown effect {effect!r}")


def library_equivalent(effect: str, truth: Truth) -> dict[str, float]:
    """The library parameter closest to the truth's form (for the estimate's error)."""
    k = truth.family.stiffness_nm_per_rad
    s = truth.spring_inv_scale2
    return {
        "valve_lag": lambda: {"tau_s": truth.valve_tau_s},
        "dead_time": lambda: {"delay_s": truth.delay_s},
        "coulomb_friction": lambda: {"torque_nm": truth.friction_kinetic_nm},
        "cubic_stiffness": lambda: {
            "k3_nm_per_rad3": {"power": 0.75 * k * s, "sinh": k * s / 6.0, "tanh": -k * s / 3.0}[
                truth.spring_form
            ]
        },
        "gravity": lambda: {"torque_nm": truth.gravity_nm * math.cos(truth.mount_deg * DEG)},
        "asymmetric_stiffness": lambda: {"stiffness_ratio": truth.asym_ratio},
        "quadratic_damping": lambda: {"c2_nms2_per_rad2": truth.drag_c2},
        "pressure_deadzone": lambda: {"threshold_kpa": truth.deadzone_kpa},
        # s·g(p/p_fs) against c·p/100 kPa: g's least-squares slope over 0..p_fs (x^0.7: 3/2.7;
        # (e^x − 1)/(e − 1): 1.5/(e − 1))
        "pressure_stiffening": lambda: {"gain": 100.0 * truth.stiffening_s / truth.family.full_scale_kpa
                                        * (1.5 / (math.e - 1.0) if truth.stiffening_form == "exp"
                                           else 3.0 / 2.7)},
        "creep": lambda: {"stiffness_ratio": truth.creep_beta},  # both branches together
        # Bouc-Wen's saturated torque K_h·z_max against Dahl's H (its travel, z_max, against θh)
        "hysteresis": lambda: {"torque_nm": truth.hysteresis_nm_per_rad * truth.hysteresis_zmax_deg * DEG},
        # Hunt-Crossley's stiffness, its damping left out (the library's onset θc, n = 1.5)
        "contact": lambda: {"stiffness_nm_per_radn": truth.contact_nm_per_rad15},
    }.get(effect, dict)()


def linear_damping(truth: Truth) -> float:
    """The damping the truth's extra physics adds to the plain finger's about rest: what a lab
    measuring its finger's B (a decrement) measures with it. Air drag's linear part, c2·ω_k:
    on an over-damped finger, whose drag must be large to show at its low speeds, it reaches
    several times B. Left out of the nominal and of the judge's plain finger, it would be a B
    many times off the nominal, counted as the drag's own visibility; a lab's nominal is off
    by its ±10 %, as for every other effect. Gravity's slope at rest (G·sin φ0 from the
    mounting angle, a quarter of k at most here) lies within the nominal's stated uncertainty
    (±25 %) and is left with the effect, k fitted beside it."""
    return truth.drag_c2 * truth.drag_knee_rad_s


def plain_finger(family: Family, truth: Truth, valve_tau_s: float, delay_s: float) -> LinearModel:
    """The truth's own plain linear finger (the battery judge's, and a lab's nominal before its
    ±10 %): the family's, with the damping the truth's physics adds (linear_damping)."""
    return LinearModel(family.inertia_kgm2, family.damping_nms_per_rad + linear_damping(truth),
                       family.stiffness_nm_per_rad, family.gain_nm_per_kpa, valve_tau_s, delay_s)


def known_effects(effect: str, shape: Shape) -> tuple[dict[str, dict[str, float]], float, float]:
    """The valve effect a lab would have measured and put in its model, with (tau, delay)."""
    if effect == "valve_lag":
        return {"dead_time": {"delay_s": shape.known_delay_s}}, 0.0, shape.known_delay_s
    if effect == "dead_time":
        return {"valve_lag": {"tau_s": shape.known_tau_s}}, shape.known_tau_s, 0.0
    return {}, 0.0, 0.0


# -- building a case --------------------------------------------------------------------------


def _run(truth: Truth, plan: ex.Plan, sensor: Sensor, additive: np.ndarray) -> tuple[Trajectory, np.ndarray]:
    if plan.controller is not None:
        loop = plan.controller()
        traj = simulate(
            truth,
            plan.rate_hz,
            plan.n,
            controller=loop,
            measure=lambda i, true: float(sensor.quantise(true + additive[i])),
            theta0_deg=plan.theta0_deg,
        )
        assert traj.measured_deg is not None
        return traj, traj.measured_deg
    traj = simulate(truth, plan.rate_hz, plan.n, command=plan.command, theta0_deg=plan.theta0_deg)
    return traj, sensor.read(traj.theta_deg, additive)


def _visibility(traj: Trajectory, plan: ex.Plan, start: LinearModel, sensor: Sensor) -> float:
    fit = refit(traj.theta_deg, traj.command_kpa, plan.rate_hz, start, plan.theta0_deg)
    return fit.residual_rms_deg / sensor.noise_rms_deg


def _distinct(effect: str, traj: Trajectory, plan: ex.Plan, start: LinearModel,
              sensor: Sensor) -> tuple[str, float]:
    """What absorbs the effect besides k, B and N, and what is left of it
    (distinct.distinct_visibility, about the truth's own plain finger `start`)."""
    return distinct_visibility(effect, traj.theta_deg, traj.command_kpa, plan.rate_hz, start,
                               plan.theta0_deg, sensor.noise_rms_deg)


def exercised(effect: str, truth: Truth, plan: ex.Plan, traj: Trajectory) -> tuple[bool, str]:
    """The physics rules of the module's table."""
    cmd, th, rate = traj.command_kpa, traj.theta_deg, plan.rate_hz
    if effect in ("valve_lag", "dead_time"):
        if np.ptp(cmd) < 1.0:
            return False, "the command never changes"
        if plan.kind == "slow_sine":
            return False, "one slow sine: k, B and N absorb a phase lag"
    if effect == "pressure_deadzone" and np.sum(cmd > truth.deadzone_kpa) / rate < 1.0:
        return False, "the command never passes the dead zone"
    if effect == "asymmetric_stiffness" and min(np.sum(th < -2.0), np.sum(th > 2.0)) / rate < 0.1:
        return False, "the finger does not bend both ways"
    if effect in ("cubic_stiffness", "gravity") and np.max(np.abs(th)) < 5.0:
        return False, "the angle stays under 5 deg"
    if effect == "quadratic_damping" and np.max(np.abs(traj.omega_rad_s)) < 0.2:
        return False, "the finger never moves fast"
    if effect in ON_REQUEST and np.max(np.abs(th)) < 5.0:
        return False, "the angle stays under 5 deg"
    return True, ""


def build(spec: CaseSpec) -> Case:
    """Makes the case: calibrates the strength unless the spec gives it."""
    spec = spec.resolved()
    family = FAMILIES[spec.family]
    shape = shape_of(spec)
    sensor = Sensor.random(_rng(spec, "sensor"))
    prng = _rng(spec, "nominal")
    factors = [float(x) for x in prng.uniform(0.9, 1.1, 3)]
    known, tau0, delay0 = known_effects(spec.effect, shape)
    nominal = LinearModel(
        family.inertia_kgm2,
        family.damping_nms_per_rad * factors[0],
        family.stiffness_nm_per_rad * factors[1],
        family.gain_nm_per_kpa * factors[2],
        tau0,
        delay0,
    )
    plan = ex.make(spec.excitation, _rng(spec, "excitation"), spec.rate_hz, family, nominal, spec.duration_s)
    additive = sensor.additive(_rng(spec, "noise"), plan.n, plan.rate_hz)
    start = plain_finger(family, Truth(family), tau0, delay0)
    contact_deg = math.inf
    if spec.effect == "contact":
        free, _ = _run(Truth(family), plan, sensor, additive)
        contact_deg = float(np.quantile(free.theta_deg, shape.contact_deg))

    def make_truth(s: float) -> Truth:
        return truth_at(spec.effect, s, family, shape, plan.top_kpa, contact_deg)

    calib: list[tuple[float, float]] = []

    def evaluate(s: float) -> tuple[float, Trajectory, np.ndarray]:
        traj, meas = _run(make_truth(s), plan, sensor, additive)
        v = _visibility(traj, plan, start, sensor)
        calib.append((s, v))
        return v, traj, meas

    if spec.effect == CLEAN:
        v, traj, meas = evaluate(0.0)
        return Case(spec, make_truth(0.0), nominal, known, sensor, plan, traj, meas, 0.0, v, True, "clean")

    typical, lo, hi = bounds(spec.effect, family, shape, plan.top_kpa)
    if spec.strength is not None:
        s = spec.strength
        v, traj, meas = evaluate(s)
    else:
        v, traj, meas = evaluate(typical)
        ok, _ = exercised(spec.effect, make_truth(typical), plan, traj)
        s = typical
        if ok:
            s, v, traj, meas = calibrate(
                evaluate,
                typical,
                v,
                traj,
                meas,
                lo,
                hi,
                float(_rng(spec, "target-" + spec.magnitude).uniform(*TARGETS[spec.magnitude])),
            )
    truth = make_truth(s)
    # the nominal and the judge's plain finger hold the truth's own damping (linear_damping);
    # the plan was made before, from the nominal the strength did not yet change
    start = plain_finger(family, truth, tau0, delay0)
    nominal = replace(nominal,
                      damping_nms_per_rad=nominal.damping_nms_per_rad + linear_damping(truth) * factors[0])
    ok, reason = exercised(spec.effect, truth, plan, traj)
    if ok and spec.effect in (*LIBRARY, *ON_REQUEST) and v < 0.4:
        ok, reason = False, "absorbed by k, B and N at every plausible size tried"
    if ok and spec.effect in LIBRARY:
        competitor, distinct = _distinct(spec.effect, traj, plan, start, sensor)
        if distinct < 0.4 and competitor:
            ok, reason = False, (f"indistinct from {competitor}: k, B, N, the sensor's offset and drift "
                                 f"and {competitor} leave {distinct:.2f} × the noise of it")
        elif distinct < 0.4:
            ok, reason = False, (f"absorbed by k, B, N and the sensor's offset and drift: they leave "
                                 f"{distinct:.2f} × the noise of it")
    return Case(
        spec,
        truth,
        nominal,
        known,
        sensor,
        plan,
        traj,
        meas,
        s,
        v,
        ok,
        reason,
        library_equivalent(spec.effect, truth),
        calib,
    )
