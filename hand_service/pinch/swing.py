"""The fingers bending sideways under the object's torque, and the swing as the hand lets go.

Gravity's torque about the pinch axis (the object's centre of mass off the axis) is carried
by the pads only as the person lets go; the two fingertips, which hold the object between
them, then bend sideways (out of the median plane) together with it: the object turns by
φ about the pinch axis against the fingers' sideways bending stiffness, a tip moment's
E I / L per finger, summed over the pair. What the pads must carry by friction is the
torque of that bend, k φ + c φ', not gravity's: as the load comes on, the object swings,
and the bend's torque overshoots gravity's (twice it when the load comes on at once, less
the slower the hand opens against the swing's period). The object turns with the tips by
φ, its angle of rotation in the grip counted on top of the friction's slip.

Each substep advances φ exactly for the torque held over it (the damped oscillator's
state transition), so a light object's fast swing (the coin's, hundreds of rad/s) is as
stable as the screwdriver's.
"""

from __future__ import annotations

import numpy as np

FINGER_YOUNG_MODULUS_PA = 1.14e6  # Shore A30 silicone, as the finger's torsion (plant.py)
FINGER_BENDING_I_M4 = 0.7 * 0.016**4 / 12.0  # 16 mm square, 30 % hollow
SIDE_DAMPING_RATIO = 0.1  # of critical, against the object's inertia: silicone's loss, an assumption


def side_stiffness_nm_per_rad(length_m: np.ndarray) -> np.ndarray:
    """The pair's sideways bending stiffness at the tips, per trial (length_m: (n, 2))."""
    return (FINGER_YOUNG_MODULUS_PA * FINGER_BENDING_I_M4 / length_m).sum(axis=1)


class Swing:
    """The object and fingertips turning together about the pinch axis, per trial."""

    def __init__(self, stiffness_nm_per_rad: np.ndarray, inertia_kgm2: np.ndarray, dt_s: float) -> None:
        self.stiffness_nm_per_rad = stiffness_nm_per_rad
        omega = np.sqrt(stiffness_nm_per_rad / inertia_kgm2)
        zeta = SIDE_DAMPING_RATIO
        self.damping_nms_per_rad = 2.0 * zeta * np.sqrt(stiffness_nm_per_rad * inertia_kgm2)
        damped = omega * np.sqrt(1.0 - zeta**2)
        decay = np.exp(-zeta * omega * dt_s)
        c, s = np.cos(damped * dt_s), np.sin(damped * dt_s)
        self._p11 = decay * (c + zeta * omega / damped * s)
        self._p12 = decay * s / damped
        self._p21 = -decay * omega**2 / damped * s
        self._p22 = decay * (c - zeta * omega / damped * s)
        self.angle_rad = np.zeros_like(stiffness_nm_per_rad)
        self.rate_rad_per_s = np.zeros_like(stiffness_nm_per_rad)

    def advance(self, torque_nm: np.ndarray) -> None:
        """One substep with gravity's torque on the pads held at torque_nm."""
        rest = torque_nm / self.stiffness_nm_per_rad
        off = self.angle_rad - rest
        self.angle_rad = rest + self._p11 * off + self._p12 * self.rate_rad_per_s
        self.rate_rad_per_s = self._p21 * off + self._p22 * self.rate_rad_per_s

    @property
    def torque_nm(self) -> np.ndarray:
        """The bend's torque, which the pads carry by friction."""
        return self.stiffness_nm_per_rad * self.angle_rad + self.damping_nms_per_rad * self.rate_rad_per_s
