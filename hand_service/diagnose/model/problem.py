"""The output-error problem `diagnose` solves: a finger model driven by the recorded input.

A `Problem` holds the recorded command and angle, the nominal finger (its inertia, lever
arm and the effects already in its `effects` block), the integration settings, the initial
state read off the data, and the split of the samples into a fitting set and a held-out
set. Parameters are named `Param`s (plain PRBM ones and library effects), so one fit routine
serves the refit of the plain model and every augmented model.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.diagnose.model.fit_cache import FitCache
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.simulation_cache import SimulationCache, finger_key
from hand_service.diagnose.residual.noise import WHITE, NoiseModel
from hand_service.simulator import check_ringing, sim_finger
from rtcore.sim import SimFinger, simulate_angle

HOLDOUT_EVERY = 4  # every 4th block is held out from fitting
BLOCKS_WANTED = 16
PLAIN = ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa")
# How the recorded command acted between samples: "zoh", held from its sample to the next
# (what the daemon and a DAQ's analog output do: the command it records is the one it
# held); "point", samples of a command that changed continuously (a measured pressure),
# taken as linear between samples.
INPUT_HOLDS = ("zoh", "point")
# the nominal model's uncertainty: a log-normal prior of this relative width on k, B and N,
# used when the recording alone cannot pin them (closed loop: only k/N; a ramp: not B)
PRIOR_RELATIVE_WIDTH = 0.25
HISTORY_SAMPLES = 1000  # the simulator's command history (RTCORE_SIM_HISTORY) with a margin


# what a fit asks of the simulator: no bound of its own on the steps (rtcore_sim_run's 0), so
# that the dynamics alone choose them and a run of samples under one held command (a step's
# hundreds at 1 kHz) takes the steps its motion needs, not one per sample (csrc/rtcore_sim_span.c)
FIT_SUBSTEPS = 0


def substeps_for(rate_hz: float) -> int:
    """Integration steps asked per sample: one. The simulator (csrc/rtcore_sim*.c) takes the
    plain linear finger exactly at any step, and chooses its own finer steps from the
    dynamics only where an effect, a valve lag or a contact needs them; so a slow recording
    costs no more than its dynamics do, and a stiff over-damped one no more than a plain."""
    del rate_hz
    return 1


@dataclass(frozen=True)
class Prior:
    """A log-normal prior on some parameters: centre (the nominal) and relative width,
    weighted by the noise's std so that it sits in the residual's units."""

    centres: dict[str, float] = dataclasses.field(default_factory=dict)
    widths: dict[str, float] = dataclasses.field(default_factory=dict)
    weight_deg: float = 0.0


NO_PRIOR = Prior()


@dataclass
class Problem:
    base: SimFinger
    pressure_kpa: np.ndarray
    measured_deg: np.ndarray
    t_s: np.ndarray
    rate_hz: float
    substeps: int
    angle0_deg: float
    chamber0_kpa: float
    fit_mask: np.ndarray  # samples the fits use
    held_mask: np.ndarray  # samples held out from every fit
    blocks: list[tuple[int, int]]  # (start, stop) index of every block, for the report
    input_hold: str = "zoh"
    # the fit and held-out masks and blocks counting the first decay times too, where these
    # skip them (the start is not known to be at rest): for use with noise.start_motion
    from_start: tuple[np.ndarray, np.ndarray, list[tuple[int, int]]] | None = None
    noise: NoiseModel = WHITE  # set once the plain model's residual is known (engine)
    # samples the recording lacks (skipped rows, timebase.regular_grid): in no fit or score,
    # the residual there interpolated from the measured samples beside them (residual);
    # None when none is missing
    missing: np.ndarray | None = None
    # the recording starts with the finger held still away from where the first command puts
    # it (released()): its first sample is its start, the sensor's offset included
    released: bool = False
    prior: Prior = NO_PRIOR  # set when the recording alone cannot pin k, B, N (engine)
    # shared by the copies that differ in their masks (rotated(), a half of the fitting set)
    # the model file's effects block: an effect searched for starts its shape (a contact's
    # onset, a loop's travel) at the values it gives, else at Effect.shape_start
    given_effects: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)
    asked: frozenset[str] = frozenset()  # `--search`'s effects: fitted whatever their screen (admission.py)
    simulations: SimulationCache = dataclasses.field(default_factory=SimulationCache, repr=False,
                                                     compare=False)
    fits: FitCache = dataclasses.field(default_factory=FitCache, repr=False, compare=False)
    _shape_starts: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict, repr=False,
                                                                    compare=False)

    def shape_start(self, name: str) -> dict[str, float]:
        """Where effect `name`'s shape parameters start (Effect.shape_start, from the
        recorded angle), once per recording."""
        if name not in self._shape_starts:
            spec = fx.BY_NAME[name]
            self._shape_starts[name] = {q.name: spec.shape_start(q.name, self.measured_deg)
                                        for q in spec.shape_parameters}
        return self._shape_starts[name]

    def shape_of(self, name: str) -> tuple[list[Param], list[float]]:
        """Effect `name`'s shape parameters, fitted beside its size, and their starts: the
        model file's values, else shape_start's."""
        spec = fx.BY_NAME[name]
        start = {**self.shape_start(name), **self.given_effects.get(name, {})}
        params = [Param.shape(name, q.name) for q in spec.shape_parameters]
        return params, [float(np.clip(start[p.member], p.lower, p.upper)) for p in params]

    @property
    def n_fit(self) -> int:
        return int(self.fit_mask.sum())

    def rotated(self) -> Problem:
        """The same recording with another quarter of its blocks held out (the first of
        every HOLDOUT_EVERY, where the held ones are the middle): a second held-out test,
        on samples disjoint from the first's."""
        valid = self.fit_mask | self.held_mask
        held = np.zeros_like(valid)
        for i, (start, stop) in enumerate(self.blocks):
            if i % HOLDOUT_EVERY == 0:
                held[start:stop] = True
        held &= valid
        return dataclasses.replace(self, fit_mask=valid & ~held, held_mask=held)

    def finger(self, params: Sequence[Param], values: Sequence[float],
               base: SimFinger | None = None) -> SimFinger:
        """The base finger with `params` set to `values`."""
        finger = base or self.base
        plain: dict[str, object] = {p.field: float(v) for p, v in zip(params, values, strict=True)
                                    if not p.is_effect}
        library = fx.registry.by_name()
        effect: dict[str, float] = {}
        hooked = []  # effects that are not terms of the C model: their own simulator hooks
        given: dict[str, dict[str, float]] = {}  # each effect's parameters set here
        for p, v in zip(params, values, strict=True):
            if p.is_effect:
                given.setdefault(p.label, {})[p.member or library[p.label].param] = float(v)
        for name, own in given.items():
            spec = library[name]
            # a shape parameter not set here: the one in `finger` when it carries the effect
            # (a later round's fit), else the model file's, else its start (shape_start)
            carried = {q.name: spec.read_parameter(finger, q.name) for q in spec.shape_parameters
                       if q.name not in own and spec.read(finger) != spec.neutral}
            merged = {**self.shape_start(name), **self.given_effects.get(name, {}), **carried, **own}
            if spec.hooked:
                hooked.append((spec, merged))
            else:
                effect.update(spec.rtcore_fields(merged))
        if effect:
            plain["effects"] = dataclasses.replace(finger.prbm.effects, **effect)
        if plain:
            finger = dataclasses.replace(finger, prbm=dataclasses.replace(finger.prbm, **plain))
        for spec, values in hooked:
            finger = spec.apply(finger, values)
        return finger

    def simulate(self, finger: SimFinger) -> np.ndarray:
        """The simulated angle at every sample (a new array: the caller may change it)."""
        if not self.simulations.serves(self.pressure_kpa):  # the recording's arrays are not changed in place
            return self._simulate_uncached(finger)
        # what else the run depends on: a copy of the problem with another start misses
        key = (finger_key(finger), self.input_hold, repr(self.rate_hz), self.substeps, repr(self.angle0_deg),
               repr(self.chamber0_kpa))
        angle = self.simulations.get(key)
        if angle is None:
            angle = self._simulate_uncached(finger)
            self.simulations.put(key, angle)
        return angle

    def _simulate_uncached(self, finger: SimFinger) -> np.ndarray:
        if self.input_hold == "point":
            return self._simulate_between_points(finger)
        return simulate_angle(finger, self.pressure_kpa, self.rate_hz, self.substeps, self.angle0_deg, 0.0,
                              self.chamber0_kpa)

    def _simulate_between_points(self, finger: SimFinger) -> np.ndarray:
        """The command linear between its samples: each sub-step holds the command at its
        middle, so the run is the same size as a held one."""
        steps = max(2, self.substeps)
        while steps > 1 and finger.prbm.effects.dead_time_s * self.rate_hz * steps >= HISTORY_SAMPLES:
            steps -= 1  # the dead time must fit the simulator's history at the finer rate
        n = self.pressure_kpa.size
        middles = (np.arange(n * steps) + 0.5) / steps
        command = np.interp(middles, np.arange(n), self.pressure_kpa)
        angle = simulate_angle(finger, command, self.rate_hz * steps, max(1, self.substeps // steps),
                               self.angle0_deg, 0.0, self.chamber0_kpa)
        return np.ascontiguousarray(angle[::steps])

    def residual(self, angle_deg: np.ndarray) -> np.ndarray:
        """measured − simulated, every sample. At a skipped sample the residual is
        interpolated between the measured ones beside it, not the angle: the angle
        interpolated across a skipped sample of a ringing finger misses the curve the
        simulation follows by degrees, which the offset and drift fitted over every sample,
        and the noise filter reaching back to it, would carry (a clean recording with 5 % of
        its rows skipped was called `unexplained`, the Ljung-Box p = 1e-18)."""
        residual = self.measured_deg - angle_deg
        if self.missing is not None:
            index = np.arange(residual.size)
            have = ~self.missing
            residual[self.missing] = np.interp(index[self.missing], index[have], residual[have])
        return residual

    def with_skipped(self, mask: np.ndarray) -> np.ndarray:
        """`mask` and the skipped samples inside its runs (the last measured sample before
        them in `mask`): the noise's correlation is estimated on evenly spaced samples, so
        that each lag stays a lag."""
        if self.missing is None:
            return mask
        measured = np.where(self.missing, -1, np.arange(mask.size))
        last = np.maximum.accumulate(measured)  # the last measured sample at or before each
        return mask | (self.missing & (last >= 0) & mask[np.maximum(last, 0)])

    def misfit(self, angle_deg: np.ndarray) -> np.ndarray:
        """measured − simulated, every sample, with the sensor's offset and slow drift taken
        out when the noise model has them (nuisance terms, fitted with every model)."""
        return self.noise.detrend(self.residual(angle_deg))

    def innovations(self, angle_deg: np.ndarray) -> np.ndarray:
        """The residual of a simulated angle through the noise model, every sample: what
        the tests take for white noise."""
        return self.noise.whiten(self.residual(angle_deg), self.with_skipped(self.fit_mask))

    def fit_rss(self, innovations: np.ndarray) -> float:
        """Sum of squared innovations (every sample's, from innovations()) on the fitting
        samples (deg²)."""
        e = innovations[self.fit_mask]
        return float(e @ e)

    def innovation_sigma(self, innovations: np.ndarray, n_params: int) -> float:
        """The innovations' std on the fitting samples, the fitted parameters taken off."""
        return float(np.sqrt(self.fit_rss(innovations) / max(self.n_fit - n_params, 1)))

    def values(self, params: Sequence[Param], finger: SimFinger | None = None) -> np.ndarray:
        finger = finger or self.base
        library = fx.registry.by_name()
        return np.array([library[p.label].read_parameter(finger, p.member or library[p.label].param)
                         if p.is_effect else getattr(finger.prbm, p.field) for p in params])


def settle_time_s(finger: SimFinger) -> float:
    """Three decay time constants of the finger's ringing, 1/(ζ·ωn) each."""
    decay_per_s = finger.prbm.damping_nms_per_rad / (2.0 * finger.prbm.inertia_kgm2)
    return 3.0 / max(decay_per_s, 1.0)


RELEASE_SHARE = 0.2  # a start this far from rest (share of the angle's range) is a release
RELEASE_BLOCK_S = 0.1  # the blocks of a release, short enough to fall among its swings


def released(finger: SimFinger, pressure0_kpa: float, angle0_deg: float, angle_deg: np.ndarray) -> bool:
    """Does the recording start with the finger held still away from where the first
    command would put it (the LDM's free release, a vent from a held pressure)? Then its
    start is known, and its first swings, the whole of the information, count."""
    prbm = finger.prbm
    rest_deg = math.degrees(prbm.pressure_gain_nm_per_kpa * pressure0_kpa / prbm.stiffness_nm_per_rad)
    return abs(angle0_deg - rest_deg) > RELEASE_SHARE * float(np.ptp(angle_deg))


def split_blocks(n: int, rate_hz: float, start: int,
                 shortest_s: float = 0.5, longest_s: float = 3.0) -> tuple[np.ndarray, np.ndarray,
                                                                        list[tuple[int, int]]]:
    """Interleaved blocks after `start`: every HOLDOUT_EVERY-th one is held out.

    Interleaving puts held-out data in every part of the excitation (steps, chirps,
    ramps), which a single held-out tail would not. Blocks last from `shortest_s` to
    `longest_s`."""
    usable = n - start
    block = int(np.clip(usable / BLOCKS_WANTED, shortest_s * rate_hz, longest_s * rate_hz))
    block = max(block, 1)
    fit = np.zeros(n, dtype=bool)
    held = np.zeros(n, dtype=bool)
    blocks = []
    for i, first in enumerate(range(start, n, block)):
        stop = min(first + block, n)
        blocks.append((first, stop))
        target = held if i % HOLDOUT_EVERY == HOLDOUT_EVERY // 2 else fit
        target[first:stop] = True
    return fit, held, blocks


def build_problem(model: FingerModel, t_s: np.ndarray, pressure_kpa: np.ndarray, angle_deg: np.ndarray,
                  rate_hz: float, missing: np.ndarray | None = None, input_hold: str = "zoh") -> Problem:
    """The model driven by the recorded command, starting from the recorded state.

    The finger is taken to start at rest at its first angle (the median of the first
    samples, to keep the sensor noise out), with the chamber at the first command. The
    first three decay times are left out of every fit and score, so that a start that is
    not quite at rest does not count (`from_start` has the masks that count them, for a
    noise model that takes the motion of such a start as a nuisance); so are `missing`
    samples (see regular_grid)."""
    base = sim_finger(model)
    check_ringing(model, base, rate_hz, "the recording's")
    # the valves as recorded: a signed command (vacuum, a bipolar drive) or one above the
    # usual supply is simulated as it is, never clamped
    base = dataclasses.replace(base, supply_min_kpa=min(base.supply_min_kpa, float(np.min(pressure_kpa))),
                               supply_max_kpa=max(base.supply_max_kpa, float(np.max(pressure_kpa))))
    substeps = FIT_SUBSTEPS
    angle0 = float(np.median(angle_deg[: max(1, int(0.05 * rate_hz))]))
    start = min(int(settle_time_s(base) * rate_hz), len(t_s) // 5)
    shortest_s, longest_s = 0.5, 3.0
    release = released(base, float(pressure_kpa[0]), float(angle_deg[0]), angle_deg)
    if release:
        # a release: the finger was held still away from rest, so its start is known; it
        # moves at once, so the first sample (not a median over 50 ms of swing: a ringing
        # finger let go from 32° is at −20° 50 ms later) tells it and places it.
        # Its swings die within a second: short blocks put held-out data among them.
        start, angle0, shortest_s, longest_s = 0, float(angle_deg[0]), RELEASE_BLOCK_S, RELEASE_BLOCK_S
    fit, held, blocks = split_blocks(len(t_s), rate_hz, start, shortest_s, longest_s)
    from_start = split_blocks(len(t_s), rate_hz, 0, shortest_s, longest_s) if start > 0 else None
    if missing is not None:  # samples the recording lacks (skipped ticks): in no fit or score
        for mask in (fit, held, *(from_start[:2] if from_start else ())):
            mask &= ~missing
    return Problem(base, np.ascontiguousarray(pressure_kpa, dtype=float),
                   np.ascontiguousarray(angle_deg, dtype=float), np.asarray(t_s, dtype=float), rate_hz,
                   substeps, angle0, float(pressure_kpa[0]), fit, held, blocks, input_hold, from_start,
                   missing=None if missing is None or not missing.any() else np.asarray(missing, dtype=bool),
                   released=release, given_effects={name: dict(v) for name, v in model.effects.items()})
