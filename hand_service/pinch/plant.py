"""The finger pair and the object as physics, vectorized over many trials at once.

Each trial is two fingers (thumb and one other) closing on an object placed between
their tips. Per finger the PRBM of docs/physics.md with the truth's valve lag and dead
time: A th'' + B th' + k th = N p - r F. The tip moves along the pinch axis by r th. The
fingers and their valves' lag are stepped by rtcore's finger simulator (rtcore.motion,
csrc/rtcore_sim_plant.h), the pads' force r F held over each substep as an external
torque; the dead time, the contacts and the object are here.

Contacts: a normal spring and damper per pad (N = k_c d + c_c d', never pulling) and
Coulomb friction with stick and slip on the object's three free motions in the grip:
vertical (gravity, and the wedge of a curved surface pinched off its centre), lateral
(the pads' tilt when the object sits off the median plane pushes it out of the pinch)
and rotation about the pinch axis (gravity's torque, resisted by torsional friction).
The three demands share one friction limit, an ellipsoid (Howe and Cutkosky's limit
surface for a soft contact): the object sticks while the demand lies inside it and
slips, driven by the excess, when it does not. Along the pinch axis the object is
light beside the fingers' effective mass (A / r^2 is about 0.1 kg), so once released it
sits where the two normal forces are equal. The person's hand opens over release_s: its
spring along the axis falls linearly to zero; the object's weight is on the pads from the
release's start, gravity's torque comes on with the hand's opening through the fingers'
sideways bend (hand_service.pinch.swing). docs/replicate.md gives every parameter.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hand_service.pinch.mismatch import NONE, Hysteresis, Mismatch, ValveLag
from hand_service.pinch.objects import GRAVITY_M_PER_S2, PinchObject, Placements
from hand_service.pinch.swing import Swing, side_stiffness_nm_per_rad
from rtcore import Effects, Prbm
from rtcore.motion import FingerMotions
from rtcore.sim import SimFinger

PAD_STIFFNESS_N_PER_M = 2500.0  # silicone pad, Hertz secant at 1 N (docs/replicate.md)
PAD_DAMPING_NS_PER_M = 10.0  # about 0.3 of critical against the finger's tip mass
PAD_RADIUS_M = 0.008  # half the finger's 16 mm width
FINGER_SHEAR_MODULUS_PA = 1.14e6 / 3.0  # Shore A30 by Gent's relation, G = E / 3
FINGER_TORSION_CONSTANT_M4 = 0.7 * 0.1406 * 0.016**4  # 16 mm square, 30 % hollow
HAND_STIFFNESS_N_PER_M = 300.0  # the person's relaxed pinch presenting the object, until release
RELEASE_S = 0.25  # the person's fingers open: their spring falls linearly to zero over this time
SLIP_LIMIT_M = 0.005  # vertical or lateral slip that counts as slipping out
ROTATION_LIMIT_RAD = 0.35  # 20 deg of rotation in the grip counts as slipping out
MAX_TILT_RAD = 1.4


@dataclass
class FingerArrays:
    """Per trial and finger (shape (n, 2)): the truth's PRBM and valve."""

    inertia_kgm2: np.ndarray
    damping_nms_per_rad: np.ndarray
    stiffness_nm_per_rad: np.ndarray
    gain_nm_per_kpa: np.ndarray
    lever_arm_m: np.ndarray
    valve_tau_s: np.ndarray
    dead_time_s: np.ndarray
    length_m: np.ndarray
    name: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=str))

    def sim_fingers(self, with_lag: bool = True) -> list[SimFinger]:
        """Every finger for rtcore's simulator, trial by trial (row-major over (n, 2)):
        its PRBM and (with_lag) valve lag; the dead time is the plant's own."""
        taus = self.valve_tau_s.ravel() if with_lag else np.zeros(self.valve_tau_s.size)
        columns = zip(self.inertia_kgm2.ravel(), self.damping_nms_per_rad.ravel(),
                      self.stiffness_nm_per_rad.ravel(), self.gain_nm_per_kpa.ravel(),
                      self.lever_arm_m.ravel(), taus, strict=True)
        return [SimFinger(Prbm(float(a), float(b), float(k), float(gain), float(lever),
                               Effects(valve_lag_tau_s=float(tau))))
                for a, b, k, gain, lever, tau in columns]

    @property
    def twist_stiffness_nm_per_rad(self) -> np.ndarray:
        """The finger's torsion about its own axis, G J / L: a short finger twists less."""
        return FINGER_SHEAR_MODULUS_PA * FINGER_TORSION_CONSTANT_M4 / self.length_m


@dataclass
class ObjectArrays:
    """Per trial (shape (n,)): the object and its placement."""

    mass_kg: np.ndarray
    width_m: np.ndarray
    friction: np.ndarray
    patch_radius_m: np.ndarray
    strip_half_width_m: np.ndarray
    edge_radius_m: np.ndarray
    vertical_radius_m: np.ndarray
    com_lever_m: np.ndarray
    lever_along_lateral: np.ndarray
    inertia_kgm2: np.ndarray
    break_force_n: np.ndarray
    lateral_m: np.ndarray
    axial_m: np.ndarray
    vertical_m: np.ndarray

    @classmethod
    def build(cls, objects: list[PinchObject], placements: list[Placements]) -> ObjectArrays:
        def per(attr: str) -> np.ndarray:
            return np.concatenate([np.full(len(p.width_m), float(getattr(o, attr)))
                                   for o, p in zip(objects, placements, strict=True)])

        def drawn(attr: str) -> np.ndarray:
            return np.concatenate([getattr(p, attr) for p in placements])

        return cls(per("mass_kg"), drawn("width_m"), per("friction"), per("patch_radius_m"),
                   per("strip_half_width_m"), per("edge_radius_m"), per("vertical_radius_m"),
                   per("com_lever_m"), per("lever_along_lateral") > 0.5, per("inertia_kgm2"),
                   drawn("break_force_n"), drawn("lateral_m"), drawn("axial_m"), drawn("vertical_m"))


# failure codes of a trial
HELD, BROKEN, SLIPPED, DROPPED = 0, 1, 2, 3
OUTCOME_NAMES = {HELD: "held", BROKEN: "broken", SLIPPED: "slipped", DROPPED: "dropped"}


class PinchPlant:
    """n trials' fingers and objects, advanced one substep at a time by `advance`."""

    def __init__(self, fingers: FingerArrays, obj: ObjectArrays, gap_m: np.ndarray, dt_s: float,
                 mismatch: Mismatch = NONE, release_s: float = RELEASE_S) -> None:
        self.f, self.o, self.dt_s, self.mismatch = fingers, obj, dt_s, mismatch
        self.release_s = release_s
        self._since_release_s = 0.0
        n = obj.mass_kg.shape[0]
        self.gap_m = gap_m
        # the board's valves (mismatch.valves) replace the profile's lag and dead time
        board = mismatch.valves
        self._motions = FingerMotions(fingers.sim_fingers(with_lag=board is None))
        self._valves = (None if board is None else
                        ValveLag(board, np.vectorize(board.fill_tau_of, otypes=[float])(fingers.name), dt_s))
        self._hysteresis = Hysteresis(np.radians(mismatch.hysteresis_deg), (n, 2))
        # views of the simulator's state, shape (n, 2): writing them places the fingers
        self.angle_rad = self._motions.angle_rad.reshape(n, 2)
        self.velocity_rad_per_s = self._motions.velocity_rad_per_s.reshape(n, 2)
        self.chamber_kpa = self._motions.chamber_kpa.reshape(n, 2)
        self.delay_steps = np.rint(fingers.dead_time_s / dt_s).astype(int) * (board is None)
        depth = int(self.delay_steps.max()) + 1
        self._pipe = np.zeros((depth, n, 2))
        self._pipe_at = 0
        lever = fingers.lever_arm_m
        # the object's centre where both fingers, equally bent, touch it together
        touch_rad = (gap_m - obj.width_m) / lever.sum(axis=1)
        self.object_axial_m = lever[:, 0] * touch_rad + obj.width_m / 2.0 + obj.axial_m
        self.released = False
        self.vertical_slip_m = np.zeros(n)
        self.lateral_slip_m = np.zeros(n)
        self.rotation_rad = np.zeros(n)  # slip in the grip about the pinch axis
        self.swing = Swing(side_stiffness_nm_per_rad(fingers.length_m), obj.inertia_kgm2, dt_s)
        self._slip_velocity = np.zeros((n, 3))
        self.normal_n = np.zeros((n, 2))
        self.peak_normal_n = np.zeros(n)
        self.outcome = np.full(n, HELD)

    def release(self) -> None:
        """The person starts to let go: their hand's spring falls to zero over release_s
        (0: at once), and from now on the fingers' friction carries the object."""
        self.released = True

    @property
    def hand_stiffness_n_per_m(self) -> float:
        """The person's hand along the pinch axis: HAND_STIFFNESS_N_PER_M until release,
        then falling linearly to zero over release_s."""
        if not self.released:
            return HAND_STIFFNESS_N_PER_M
        if self.release_s <= 0.0:
            return 0.0
        return HAND_STIFFNESS_N_PER_M * max(1.0 - self._since_release_s / self.release_s, 0.0)

    def _object_axial(self, tip: np.ndarray, tip_rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where the object sits along the pinch axis, and its rate: the two pads' springs
        and, until release, the person's hand (a spring to the placed position) in
        balance. The balance is monotonic in the position: one case is consistent."""
        o, k_c = self.o, PAD_STIFFNESS_N_PER_M
        k_h = self.hand_stiffness_n_per_m
        left_face = tip[:, 0] + o.width_m / 2.0  # object centre at which the thumb's pad just touches
        right_face = self.gap_m - tip[:, 1] - o.width_m / 2.0
        placed = self.object_axial_m
        both = (k_c * (left_face + right_face) + k_h * placed) / (2.0 * k_c + k_h)
        left = (k_c * left_face + k_h * placed) / (k_c + k_h)
        right = (k_c * right_face + k_h * placed) / (k_c + k_h)
        free = placed if k_h > 0.0 else (left_face + right_face) / 2.0
        free_rate = 0.0 if k_h > 0.0 else (tip_rate[:, 0] - tip_rate[:, 1]) / 2.0
        in_both = (both < left_face) & (both > right_face)
        in_left = ~in_both & (left < left_face) & (left <= right_face)
        in_right = ~in_both & ~in_left & (right > right_face) & (right >= left_face)
        x = np.where(in_both, both, np.where(in_left, left, np.where(in_right, right, free)))
        rate = np.where(in_both, k_c * (tip_rate[:, 0] - tip_rate[:, 1]) / (2.0 * k_c + k_h),
                        np.where(in_left, k_c * tip_rate[:, 0] / (k_c + k_h),
                                 np.where(in_right, -k_c * tip_rate[:, 1] / (k_c + k_h), free_rate)))
        return x, rate

    def _overlaps(self) -> tuple[np.ndarray, np.ndarray]:
        lever = self.f.lever_arm_m
        tip = lever * self.angle_rad
        tip_rate = lever * self.velocity_rad_per_s
        x, rate = self._object_axial(tip, tip_rate)
        left = tip[:, 0] + self.o.width_m / 2.0 - x
        right = x - (self.gap_m - tip[:, 1] - self.o.width_m / 2.0)
        rates = np.stack([tip_rate[:, 0] - rate, tip_rate[:, 1] + rate], axis=1)
        return np.stack([left, right], axis=1), rates

    def advance(self, command_kpa: np.ndarray) -> None:
        """One substep with the valves commanded to command_kpa (shape (n, 2))."""
        f, dt = self.f, self.dt_s
        self._pipe[self._pipe_at] = command_kpa
        depth = self._pipe.shape[0]
        trials = np.arange(command_kpa.shape[0])[:, None]
        delayed = self._pipe[(self._pipe_at - self.delay_steps) % depth, trials, np.arange(2)[None, :]]
        self._pipe_at = (self._pipe_at + 1) % depth
        depth_m, rate_m_per_s = self._overlaps()
        normal = np.where(depth_m > 0.0,
                          np.maximum(PAD_STIFFNESS_N_PER_M * depth_m
                                     + PAD_DAMPING_NS_PER_M * rate_m_per_s, 0.0),
                          0.0)
        self.normal_n = normal
        lever = self.mismatch.contact_lever_m(f.lever_arm_m, self.angle_rad)
        extra = self.mismatch.stiffening_torque_nm(f.stiffness_nm_per_rad, self.angle_rad,
                                                   self.chamber_kpa)
        if self.mismatch.hysteresis_deg > 0.0:
            extra = extra + self._hysteresis.torque_nm(f.stiffness_nm_per_rad, self.angle_rad)
        if self._valves is not None:
            delayed = self._valves.step(delayed)
        self._motions.advance(delayed, -lever * normal - extra, dt)
        self.peak_normal_n = np.maximum(self.peak_normal_n, normal.max(axis=1))
        going = self.outcome == HELD
        self.outcome[going & (self.peak_normal_n > self.o.break_force_n)] = BROKEN
        if self.released:
            self._since_release_s += dt
            self._grip(normal)

    def tilt_rad(self, normal: np.ndarray) -> np.ndarray:
        """Each pad's contact normal off the pinch axis, across the median plane: the
        geometry of a pad meeting the surface's edge, plus the finger's own twist."""
        o = self.o
        offset = np.abs(o.lateral_m + self.lateral_slip_m)
        past_strip = np.maximum(offset - o.strip_half_width_m, 0.0)
        geometric = np.arcsin(np.minimum(past_strip / (PAD_RADIUS_M + o.edge_radius_m), 0.99))
        # a surface narrower than the pad (a coin's rim) cannot hold the pad's face square:
        # the off-centre normal force twists the finger and tilts the contact with it
        narrow = (o.strip_half_width_m < PAD_RADIUS_M)[:, None]
        twist = np.where(narrow, normal * offset[:, None] / self.f.twist_stiffness_nm_per_rad, 0.0)
        return np.minimum(geometric[:, None] + twist, MAX_TILT_RAD)

    def gravity_torque_nm(self) -> np.ndarray:
        """Gravity's torque on the object about the pinch axis, turned as it is in the grip."""
        o = self.o
        lever = o.com_lever_m + np.where(o.lever_along_lateral, o.lateral_m + self.lateral_slip_m, 0.0)
        return o.mass_kg * GRAVITY_M_PER_S2 * lever * np.cos(self.rotation_rad + self.swing.angle_rad)

    def demand(self, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """What friction must supply to hold the object still (n, 3): vertical force
        (down +), lateral force (out +), torque about the pinch axis (the fingers' sideways
        bend's, hand_service.pinch.swing); and the limits."""
        o = self.o
        total_n = normal.sum(axis=1)
        weight = o.mass_kg * GRAVITY_M_PER_S2
        height = o.vertical_m + self.vertical_slip_m  # the pinch axis above the object's centre
        curved = np.isfinite(o.vertical_radius_m)
        radius = np.where(curved, o.vertical_radius_m, 1.0)
        wedge = np.where(curved, np.clip(height / radius, -0.99, 0.99), 0.0)
        vertical = weight + total_n * wedge
        lateral = (normal * np.tan(self.tilt_rad(normal))).sum(axis=1)
        torque = self.swing.torque_nm
        friction = o.friction * total_n
        limits = np.stack([friction, friction, 2.0 / 3.0 * friction * o.patch_radius_m], axis=1)
        return np.stack([vertical, lateral, torque], axis=1), limits

    def _grip(self, normal: np.ndarray) -> None:
        o, dt = self.o, self.dt_s
        going = self.outcome == HELD
        # the pads take gravity's torque as the person's hand lets go of the object
        carried = 1.0 - self.hand_stiffness_n_per_m / HAND_STIFFNESS_N_PER_M
        self.swing.advance(np.where(going, carried * self.gravity_torque_nm(), 0.0))
        load, limits = self.demand(normal)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.sqrt(((load / limits) ** 2).sum(axis=1))
        ratio = np.where(limits[:, 0] > 0.0, ratio, np.inf)
        slipping = ratio > 1.0
        excess = np.where(slipping, 1.0 - 1.0 / np.where(slipping, ratio, 1.0), 0.0)
        mass = np.stack([o.mass_kg, o.mass_kg, o.inertia_kgm2], axis=1)
        accel = np.where(np.isfinite(ratio)[:, None], load * excess[:, None] / mass, load / mass)
        self._slip_velocity = np.where(slipping[:, None], self._slip_velocity + dt * accel, 0.0)
        self._slip_velocity[~going] = 0.0
        self.vertical_slip_m += dt * self._slip_velocity[:, 0]
        sign = np.where(o.lateral_m >= 0.0, 1.0, -1.0)
        self.lateral_slip_m += dt * self._slip_velocity[:, 1] * sign
        self.rotation_rad += dt * self._slip_velocity[:, 2]
        out = ((np.abs(self.vertical_slip_m) > SLIP_LIMIT_M) | (np.abs(self.lateral_slip_m) > SLIP_LIMIT_M)
               | (np.abs(self.rotation_rad + self.swing.angle_rad) > ROTATION_LIMIT_RAD))
        self.outcome[going & out] = SLIPPED
        self.outcome[going & ~out & (normal.sum(axis=1) <= 0.0)] = DROPPED

    @property
    def slip_m(self) -> np.ndarray:
        """Slip in the grip: the largest of vertical, lateral and the rotation's arc at 10 mm."""
        return np.maximum.reduce([np.abs(self.vertical_slip_m), np.abs(self.lateral_slip_m),
                                  np.abs(self.rotation_rad) * 0.010])
