"""The finger model of docs/formats.md: PRBM parameters, geometry and effects, in YAML.

A model file holds one finger. A firmware profile holds five under `hand:`; wherever a
model is asked for, `--model PROFILE.yaml --finger NAME` works too.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hand_service.config import effects as fx
from hand_service.config.schema import Key, Section, expect_mapping, validate
from hand_service.config.yamlio import LineDict, dump_yaml
from hand_service.errors import UserError
from rtcore import Prbm

GRAVITY_M_PER_S2 = 9.81

MODEL_SECTION = Section(
    "Finger model",
    "A finger's PRBM (docs/physics.md §1). Model files hold these keys at the top level; a "
    "profile's finger blocks hold them too.",
    (
        Key("finger", "finger name (optional in a model file)", "str", default=None),
        Key("inertia_kgm2", "A, effective inertia; computed as (7/12)·m·γ³·l² when absent",
            unit="kg·m²", default=None, min=0.0, min_exclusive=True),
        Key("damping_nms_per_rad", "B, viscous damping (from identify)", unit="N·m·s/rad",
            default=None, min=0.0),
        Key("stiffness_nm_per_rad", "k, torsional stiffness (from identify)", unit="N·m/rad",
            default=None, min=0.0, min_exclusive=True),
        Key("pressure_gain_nm_per_kpa", "N, torque per kPa of chamber pressure (calibrate gain)",
            unit="N·m/kPa", default=None, min=0.0, min_exclusive=True),
        Key("mass_kg", "finger mass m (for A)", unit="kg", default=None, min=0.0,
            min_exclusive=True),
        Key("length_m", "finger length l (for A and the lever arm)", unit="m", default=None,
            min=0.0, min_exclusive=True),
        Key("gamma", "γ, the rotating segment's share of the length", default=None, min=0.0,
            max=1.0, min_exclusive=True),
        Key("lever_arm_m", "r, pivot to force point; default γ·l/2", unit="m", default=None,
            min=0.0, min_exclusive=True),
        Key("effects", "physics the model already includes (docs/formats.md effect table)",
            "mapping", default=None),
    ),
)
MODEL_KEYS = tuple(k.name for k in MODEL_SECTION.keys)
# what a model needs beyond A to be a PRBM the controller or the simulator can run
# beside the inertia A: what every use of the model needs, and the force point, which only
# a force (estimated, controlled or met at a contact) needs
PRBM_KEYS = ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa")
FORCE_POINT_KEY = "lever_arm_m"


def inertia_from_geometry(mass_kg: float, length_m: float, gamma: float) -> float:
    """The paper's Lagrangian inertia A = (7/12)·m·γ³·l² (docs/physics.md §1)."""
    return 7.0 / 12.0 * mass_kg * gamma**3 * length_m**2


@dataclass
class FingerModel:
    inertia_kgm2: float
    stiffness_nm_per_rad: float | None = None
    damping_nms_per_rad: float | None = None
    pressure_gain_nm_per_kpa: float | None = None
    lever_arm_m: float | None = None
    finger: str | None = None
    mass_kg: float | None = None
    length_m: float | None = None
    gamma: float | None = None
    effects: fx.EffectParams = field(default_factory=dict)
    source: str = "model"

    def require(self, *names: str, purpose: str = "") -> None:
        """UserError naming the first absent parameter, and what needs it."""
        for name in names:
            if getattr(self, name) is None:
                why = f" for {purpose}" if purpose else ""
                raise UserError(f"{self.source}: the model has no '{name}', needed{why}")

    def require_prbm(self, purpose: str, force_point: bool = True) -> None:
        """UserError unless the model is a PRBM (k, B, N beside A) and, when `force_point`,
        has the lever arm r a force needs."""
        self.require(*PRBM_KEYS, *((FORCE_POINT_KEY,) if force_point else ()), purpose=purpose)

    def prbm(self, purpose: str, extra_effects: fx.EffectParams | None = None,
             force_point: bool = True) -> Prbm:
        """The rtcore PRBM of this model, for the controller and the simulator alike: the one
        place a model's parameters are copied into rtcore. `extra_effects` join the model's
        own (a simulated truth the model does not know); `purpose` is for the UserError
        when a parameter is absent. Without `force_point`, a model with no lever arm is
        enough (a free finger: no force is computed), and its lever arm is 0: no force point."""
        self.require_prbm(purpose, force_point)
        return Prbm(
            inertia_kgm2=self.inertia_kgm2,
            damping_nms_per_rad=self.damping_nms_per_rad,  # type: ignore[arg-type]
            stiffness_nm_per_rad=self.stiffness_nm_per_rad,  # type: ignore[arg-type]
            pressure_gain_nm_per_kpa=self.pressure_gain_nm_per_kpa,  # type: ignore[arg-type]
            lever_arm_m=0.0 if self.lever_arm_m is None else self.lever_arm_m,
            effects=fx.to_rtcore({**self.effects, **(extra_effects or {})}),
        )

    @property
    def natural_freq_rad_per_s(self) -> float:
        self.require("stiffness_nm_per_rad")
        return math.sqrt(self.stiffness_nm_per_rad / self.inertia_kgm2)  # type: ignore[operator]

    @property
    def damping_ratio(self) -> float:
        self.require("stiffness_nm_per_rad", "damping_nms_per_rad")
        return self.damping_nms_per_rad / (2.0 * math.sqrt(  # type: ignore[operator]
            self.stiffness_nm_per_rad * self.inertia_kgm2))  # type: ignore[operator]

    def with_changes(self, **changes: Any) -> FingerModel:
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The docs/formats.md keys in a stable order, absent ones left out."""
        data: dict[str, Any] = {}
        for name in MODEL_KEYS:
            value = getattr(self, name)
            if name == "effects":
                if value:
                    data[name] = {k: dict(v) for k, v in value.items()}
            elif value is not None:
                data[name] = value
        return data


def model_from_mapping(data: LineDict, source: str | Path, context: str = "",
                       extra: tuple[str, ...] = ()) -> tuple[FingerModel, dict[str, Any]]:
    """Validate the model keys of a mapping; returns the model and the `extra` values."""
    values = validate(data, MODEL_SECTION, source, context, extra=extra)
    effects = fx.parse_effects(values.pop("effects"), source,
                               f"{context}.effects" if context else "effects")
    inertia = values.pop("inertia_kgm2")
    geometry = [values["mass_kg"], values["length_m"], values["gamma"]]
    if inertia is None:
        if any(v is None for v in geometry):
            label = f"{context}: " if context else ""
            raise UserError(f"{source}:{getattr(data, 'line', '?')}: {label}give inertia_kgm2, or "
                            "mass_kg, length_m and gamma to compute it")
        try:
            inertia = inertia_from_geometry(*geometry)  # type: ignore[arg-type]
        except OverflowError:
            inertia = math.inf
        if not 0.0 < inertia < math.inf:
            label = f"{context}: " if context else ""
            raise UserError(f"{source}:{getattr(data, 'line', '?')}: {label}mass_kg, length_m and gamma "
                            f"give an inertia of {inertia:g} kg·m²: not a finger's (check their units)")
    if values["lever_arm_m"] is None and values["length_m"] is not None and values["gamma"] is not None:
        values["lever_arm_m"] = values["gamma"] * values["length_m"] / 2.0
        if not 0.0 < values["lever_arm_m"] < math.inf:
            raise UserError(f"{source}:{getattr(data, 'line', '?')}: {f'{context}: ' if context else ''}"
                            f"the lever arm gamma·length_m/2 = {values['lever_arm_m']:g} m is not a "
                            "finger's; give lever_arm_m")
    rest = {k: data[k] for k in extra if k in data}
    model = FingerModel(inertia_kgm2=inertia, effects=effects, source=str(source),
                        **{k: v for k, v in values.items() if k in MODEL_KEYS})
    return model, rest


def save_model(model: FingerModel, path: str | Path, header: str = "") -> None:
    """Write a model file in the docs/formats.md format (readable by load_model)."""
    text = "".join(f"# {line}\n" for line in header.splitlines()) + dump_yaml(model.to_dict())
    try:
        Path(path).write_text(text)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None


def gravity_torque_nm(model: FingerModel) -> float:
    """G = m·g·r_c with the centre of mass at the middle of the moving segment."""
    model.require("mass_kg", "length_m", "gamma", purpose="the gravity torque")
    return model.mass_kg * GRAVITY_M_PER_S2 * model.gamma * model.length_m / 2.0  # type: ignore[operator]


__all__ = ["FORCE_POINT_KEY", "MODEL_KEYS", "MODEL_SECTION", "PRBM_KEYS", "FingerModel", "expect_mapping",
           "gravity_torque_nm", "inertia_from_geometry", "model_from_mapping", "save_model"]
