"""What an effect is: a named physical form, its parameters (unit, range, neutral value) and
its simulator hook, the change it makes to a simulated finger (docs/formats.md §2.1).

Two kinds of hook exist. A `FieldEffect` is a term of the C model (csrc/rtcore_model.c,
rtcore_effects): the simulator, the controller's feedforward and its force estimate all
use it. A `FingerEffect` sets the simulated finger's own physics (csrc/rtcore_sim_plant.h:
an object past an angle, a loop in the angle): the simulator includes it in the truth; the
controller models it only through `controller_fields` (the loop's copy in rtcore_effects).
A lab's effect (registry.py) may be either, built from the simulator's terms.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from rtcore import Effects
from rtcore.sim import SimFinger


@dataclass(frozen=True)
class Parameter:
    """One parameter of an effect: its name (with its unit in it), unit, the value that
    means "no effect", its plausible range (validation and fit bounds) and a typical
    magnitude (starting points and step sizes)."""

    name: str
    unit: str
    neutral: float
    lower: float
    upper: float
    scale: float
    # `diagnose` fits it (beside the first) when it searches for the effect; false for a
    # parameter the recording cannot tell apart from another (a reference that only sets
    # the first one's units)
    fitted: bool = True


class FitScales(Protocol):
    """What sets an effect's plausible size in one recording (diagnose's EffectScales)."""

    stiffness_nm_per_rad: float
    command_max_kpa: float
    torque_nm: float
    speed_rad_s: float
    angle_rad: float


@dataclass(frozen=True)
class DerivedSize:
    """A quantity derived from an effect's parameters (Effect.derived_size)."""

    value: float
    unit: str
    what: str  # in words, for the report: "the spring's torque at 63.2°"


@dataclass(frozen=True)
class Effect(ABC):
    """A named effect. `diagnose` fits `parameters[0]` (its size: neutral is "no effect")
    and, beside it, the others marked `fitted` (its shape: an onset, a travel, a time), each
    from the value the model file gives, else from `shape_start`."""

    name: str
    physics: str  # the form, in one line (docs/formats.md §2.1)
    parameters: tuple[Parameter, ...]
    reference: str = ""  # where the form comes from
    compensated: bool = False  # the controller's model includes it (feedforward, force estimate)
    # `diagnose` searches for it (an effect whose onset or shape it cannot fit yet is
    # simulated and compensated, not searched: docs/effects.md)
    searched: bool = True
    # fitted only where its screen beats every other searched effect's by the naming margin
    # (diagnose/search/admission.py): an effect that can stand in for the others' physics
    admitted_by_screen: bool = False

    # --- the primary parameter, as the one-parameter table had it ---------------------
    @property
    def param(self) -> str:
        return self.parameters[0].name

    @property
    def unit(self) -> str:
        return self.parameters[0].unit

    @property
    def neutral(self) -> float:
        return self.parameters[0].neutral

    @property
    def lower(self) -> float:
        return self.parameters[0].lower

    @property
    def upper(self) -> float:
        return self.parameters[0].upper

    @property
    def scale(self) -> float:
        return self.parameters[0].scale

    def parameter(self, name: str) -> Parameter:
        return next(p for p in self.parameters if p.name == name)

    def full(self, values: Mapping[str, float]) -> dict[str, float]:
        """Every parameter's value: the given ones, the rest at their neutral."""
        return {p.name: float(values.get(p.name, p.neutral)) for p in self.parameters}

    # --- the simulator hook ------------------------------------------------------------
    def rtcore_fields(self, values: Mapping[str, float]) -> dict[str, float]:
        """The controller's and simulator's rtcore_effects fields this effect sets."""
        del values
        return {}

    @property
    def hooked(self) -> bool:
        """Its simulator hook sets the simulated finger beyond the C model's fields (apply
        must run for the simulator to include it)."""
        return True

    @abstractmethod
    def apply(self, finger: SimFinger, values: Mapping[str, float]) -> SimFinger:
        """`finger` with this effect at `values` (a new SimFinger)."""

    @abstractmethod
    def read(self, finger: SimFinger) -> float:
        """The primary parameter's value in `finger`."""

    def read_parameter(self, finger: SimFinger, name: str) -> float:
        """Parameter `name`'s value in `finger` (the primary's by default: a subclass with
        more parameters reads them)."""
        if name != self.param:
            raise KeyError(f"{self.name}: cannot read {name} from a simulated finger")
        return self.read(finger)

    @property
    def shape_parameters(self) -> tuple[Parameter, ...]:
        """The parameters beyond the first that `diagnose` fits beside it."""
        return tuple(p for p in self.parameters[1:] if p.fitted)

    def shape_start(self, name: str, angle_deg: Sequence[float]) -> float:
        """Where the fit of shape parameter `name` starts when the model file does not give
        it, from the recorded angle (`angle_deg`): by default its neutral."""
        del angle_deg
        return self.parameter(name).neutral

    # --- diagnose ----------------------------------------------------------------------
    def derived_size(self, values: Mapping[str, float], deepest_deg: float) -> DerivedSize | None:
        """Where the parameters trade with one another (a size whose units change with a
        shape parameter), the quantity the recording fixes, from every parameter's value
        (`values`) and the deepest angle the finger reached: `diagnose` asks that it, not the
        size, stand clear of "no effect" (0). None (the default): the size itself."""
        del values, deepest_deg
        return None

    @property
    def refining(self) -> tuple[str, ...]:
        """Shape parameters that only refine the effect and cannot carry it alone (a
        contact's damper): `diagnose` names the effect only where it beats the plain model
        with these held at their neutral too."""
        return ()

    def core_starts(self, values: Mapping[str, float], deepest_deg: float) -> list[dict[str, float]]:
        """Starts beside `values` (a joint fit's, its refining parameters dropped) for the
        refit of the effect without its refining parameters: the refit from the joint's
        values alone can end in a poorer local minimum. None by default."""
        del values, deepest_deg
        return []

    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        """The fit's bounds in a recording (`scale`, `lower`, `upper`: the table's, already
        grown with the finger's stiffness): by default the table's."""
        del scales, scale
        return lower, upper


@dataclass(frozen=True)
class FieldEffect(Effect):
    """An effect that is a term of the C model: its first parameter one field of
    rtcore_effects, its others (`more_fields`) more."""

    rtcore_field: str = ""
    compensated: bool = True
    more_fields: tuple[tuple[str, str], ...] = ()  # (parameter, rtcore_effects field) beyond the first

    def rtcore_fields(self, values: Mapping[str, float]) -> dict[str, float]:
        full = self.full(values)
        more = {field: full[param] for param, field in self.more_fields}
        return {self.rtcore_field: full[self.param], **more}

    @property
    def hooked(self) -> bool:
        return False

    def apply(self, finger: SimFinger, values: Mapping[str, float]) -> SimFinger:
        effects: Effects = dataclasses.replace(finger.prbm.effects, **self.rtcore_fields(values))
        return dataclasses.replace(finger, prbm=dataclasses.replace(finger.prbm, effects=effects))

    def read(self, finger: SimFinger) -> float:
        return float(getattr(finger.prbm.effects, self.rtcore_field))

    def read_parameter(self, finger: SimFinger, name: str) -> float:
        if name == self.param:
            return self.read(finger)
        return float(getattr(finger.prbm.effects, dict(self.more_fields)[name]))


@dataclass(frozen=True)
class FingerEffect(Effect):
    """An effect that sets the simulated finger's own fields (rtcore_sim_finger): `fields`
    maps each parameter to the finger's field it sets (a subclass may convert them by
    overriding `finger_fields`)."""

    fields: tuple[tuple[str, str], ...] = ()  # (parameter, SimFinger field)
    # (parameter, rtcore_effects field): the controller's model of it, where it has one (the
    # simulator leaves these fields to the controller and simulates the finger's `fields`)
    controller_fields: tuple[tuple[str, str], ...] = ()

    def rtcore_fields(self, values: Mapping[str, float]) -> dict[str, float]:
        if not self.controller_fields:
            return {}
        full = self.full(values)
        return {field: full[param] for param, field in self.controller_fields}

    def finger_fields(self, finger: SimFinger, values: Mapping[str, float]) -> dict[str, float]:
        full = self.full(values)
        return {field: full[param] for param, field in self.fields}

    def apply(self, finger: SimFinger, values: Mapping[str, float]) -> SimFinger:
        return dataclasses.replace(finger, **self.finger_fields(finger, values))

    def read(self, finger: SimFinger) -> float:
        return float(getattr(finger, dict(self.fields)[self.param]))

    def read_parameter(self, finger: SimFinger, name: str) -> float:
        return float(getattr(finger, dict(self.fields)[name]))
