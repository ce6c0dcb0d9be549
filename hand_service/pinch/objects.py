"""The three objects of the paper's pinch test and the hand that places them.

Every number here has its source or its reasoning in docs/replicate.md ("The pinch").
Lengths in m, masses in kg, forces in N. The pinch axis joins the two fingertips; the
median plane is the plane the fingers bend in; "lateral" is across it; "vertical" is
along gravity, in the median plane, across the pinch axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY_M_PER_S2 = 9.81


@dataclass(frozen=True)
class PinchObject:
    name: str
    mass_kg: float
    width_m: float  # between the two contact surfaces, along the pinch axis
    width_sd_m: float  # from one specimen to the next
    friction: float  # Coulomb coefficient against the silicone pad (stick and slip alike)
    patch_radius_m: float  # contact patch radius: the lever of torsional friction
    strip_half_width_m: float  # half the contact surface's extent across the median plane
    edge_radius_m: float  # the surface's edge radius beyond that strip
    vertical_radius_m: float  # surface curvature radius in the vertical direction (inf: flat)
    com_lever_m: float  # centre of mass from the pinch axis, horizontal (gravity torque)
    lever_along_lateral: bool  # the lateral placement offset moves the grip along the object
    inertia_kgm2: float  # about the pinch axis
    break_scale_n: float  # Weibull scale of the force that breaks it (inf: unbreakable)
    break_modulus: float  # Weibull modulus


# A potato chip: 2 g, 1.5 mm thick, breaks at a Weibull(modulus 4) force of mean 1.58 N.
CHIP = PinchObject(
    name="chip", mass_kg=0.002, width_m=0.0015, width_sd_m=0.0002, friction=0.35,
    patch_radius_m=0.003, strip_half_width_m=0.015, edge_radius_m=0.0005,
    vertical_radius_m=math.inf, com_lever_m=0.015, lever_along_lateral=False,
    inertia_kgm2=0.002 * (0.025**2 / 2.0 + 0.015**2),  # a 50 mm disc about its normal, 15 mm off centre
    break_scale_n=1.58 / math.gamma(1.0 + 1.0 / 4.0), break_modulus=4.0,
)

# A small screwdriver, 25 g, pinched across its 12 mm handle 10 mm from the handle's end,
# the shaft horizontal and across the median plane: the centre of mass 30 mm away.
SCREWDRIVER = PinchObject(
    name="screwdriver", mass_kg=0.025, width_m=0.012, width_sd_m=0.0, friction=0.8,
    patch_radius_m=0.004, strip_half_width_m=0.05, edge_radius_m=0.006,
    vertical_radius_m=0.006, com_lever_m=0.030, lever_along_lateral=True,
    inertia_kgm2=0.025 * (0.13**2 / 12.0 + 0.030**2),  # a uniform 130 mm rod, 30 mm off its centre
    break_scale_n=math.inf, break_modulus=1.0,
)

# A 50 euro cent coin (Nordic gold, a brass): 7.80 g, 24.25 mm across, 2.38 mm thick,
# pinched on its rim across a diameter, its face in the median plane.
COIN = PinchObject(
    name="coin", mass_kg=0.0078, width_m=0.02425, width_sd_m=0.0, friction=0.5,
    patch_radius_m=0.00119, strip_half_width_m=0.00119, edge_radius_m=0.0002,
    vertical_radius_m=0.02425 / 2.0, com_lever_m=0.0, lever_along_lateral=False,
    inertia_kgm2=0.0078 * (0.02425 / 2.0) ** 2 / 4.0,  # a thin disc about a diameter
    break_scale_n=math.inf, break_modulus=1.0,
)

OBJECTS = (CHIP, SCREWDRIVER, COIN)
OBJECT_NAMES = tuple(o.name for o in OBJECTS)
PAPER_LABELS = {"chip": "Potato Chip", "screwdriver": "Screwdriver", "coin": "Brass Coin"}


@dataclass(frozen=True)
class PlacementSpread:
    """How a person's hand places the object between the fingertips (1 sigma, m)."""

    lateral_sd_m: float = 0.0015  # off the median plane
    axial_half_range_m: float = 0.002  # along the pinch axis, uniform
    vertical_sd_m: float = 0.0015  # the pinch axis off the object's centre, vertically


SPREAD = PlacementSpread()


@dataclass
class Placements:
    """One draw per trial: arrays of length n_trials."""

    lateral_m: np.ndarray
    axial_m: np.ndarray
    vertical_m: np.ndarray
    width_m: np.ndarray
    break_force_n: np.ndarray

    @classmethod
    def draw(cls, obj: PinchObject, n: int, rng: np.random.Generator,
             spread: PlacementSpread = SPREAD) -> Placements:
        width = obj.width_m + obj.width_sd_m * rng.standard_normal(n)
        if math.isfinite(obj.break_scale_n):
            breaks = obj.break_scale_n * rng.weibull(obj.break_modulus, n)
        else:
            breaks = np.full(n, np.inf)
        return cls(spread.lateral_sd_m * rng.standard_normal(n),
                   rng.uniform(-spread.axial_half_range_m, spread.axial_half_range_m, n),
                   spread.vertical_sd_m * rng.standard_normal(n), np.maximum(width, 0.0005), breaks)

    @classmethod
    def nominal(cls, obj: PinchObject, n: int) -> Placements:
        """Centred on every axis, a specimen of nominal width and median strength."""
        median = (obj.break_scale_n * math.log(2.0) ** (1.0 / obj.break_modulus)
                  if math.isfinite(obj.break_scale_n) else math.inf)
        zeros = np.zeros(n)
        return cls(zeros, zeros.copy(), zeros.copy(), np.full(n, obj.width_m), np.full(n, median))

    @classmethod
    def regrasped(cls, obj: PinchObject, n: int, rng: np.random.Generator) -> Placements:
        """One nominal specimen (nominal width, median strength) put into the hand n times,
        each with the person's placement scatter."""
        drawn, nominal = cls.draw(obj, n, rng), cls.nominal(obj, n)
        return cls(drawn.lateral_m, drawn.axial_m, drawn.vertical_m, nominal.width_m, nominal.break_force_n)

    def tiled(self, times: int) -> Placements:
        """These placements repeated `times` times over, in order."""
        return Placements(*(np.tile(a, times) for a in (self.lateral_m, self.axial_m, self.vertical_m,
                                                        self.width_m, self.break_force_n)))
