"""The C control step through cffi: configure once, then step() with no allocation.

    hand = Hand(config)
    hand.inputs.sensor_mv[:] = mv          # numpy views straight into the C structs
    hand.inputs.mode[:] = MODE_POSITION
    hand.step()
    hand.outputs.pressure_cmd_kpa          # likewise
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.arrays import Inputs, Outputs, field_names
from rtcore.config import ConfigError, HandConfig

_DTYPES = {"double": np.float64, "int32_t": np.int32, "uint32_t": np.uint32}


def struct_view(struct: object, name: str, n: int) -> np.ndarray:
    member = getattr(struct, name)
    dtype = _DTYPES[ffi.typeof(member).item.cname]
    return np.frombuffer(ffi.buffer(member), dtype=dtype)[:n]


_Plan = tuple[tuple[str, "_Plan | None"], ...]
_PLANS: dict[type, _Plan] = {}  # per dataclass: its fields, and the nested ones' plans


def _plan(source: object) -> _Plan:
    fields = dataclasses.fields(source)  # type: ignore[arg-type]
    values = [getattr(source, f.name) for f in fields]
    return tuple((f.name, _plan(v) if dataclasses.is_dataclass(v) else None)
                 for f, v in zip(fields, values, strict=True))


def _copy(target: object, source: object, plan: _Plan) -> None:
    for name, nested in plan:
        if nested is None:
            setattr(target, name, getattr(source, name))
        else:
            _copy(getattr(target, name), getattr(source, name), nested)


def _fill(target: object, source: object) -> None:
    """Copy a (nested) dataclass into a C struct field by field, by name (the fields found
    once per dataclass: diagnose fills a finger for every simulation)."""
    plan = _PLANS.get(type(source))
    if plan is None:
        plan = _PLANS.setdefault(type(source), _plan(source))
    _copy(target, source, plan)


def to_c_config(config: HandConfig) -> object:
    c_config = ffi.new("rtcore_hand_config *")
    if not 1 <= config.n_fingers <= lib.RTCORE_MAX_FINGERS:
        raise ConfigError(f"a hand has 1 to {lib.RTCORE_MAX_FINGERS} fingers, not {config.n_fingers}")
    c_config.n_fingers = config.n_fingers
    c_config.sample_rate_hz = config.sample_rate_hz
    for i, finger in enumerate(config.fingers):
        _fill(c_config.finger[i], finger)
    return c_config


def error_message(code: int, finger: int) -> str:
    where = f"finger {finger}: " if finger >= 0 else ""
    return where + ffi.string(lib.rtcore_error_name(code)).decode()


class Hand:
    """A configured hand in caller-owned C memory, stepped in one call.

    `step()` runs one control tick for every finger and returns the OR of the output
    flags. It is bound once to the C function with its three struct pointers.
    """

    def __init__(self, config: HandConfig) -> None:
        self._hand = ffi.new("rtcore_hand *")
        self._in = ffi.new("rtcore_inputs *")
        self._out = ffi.new("rtcore_outputs *")
        self.config = config
        self.configure(config)
        n = config.n_fingers
        self.inputs = Inputs(**{name: struct_view(self._in, name, n) for name in field_names(Inputs)})
        self.outputs = Outputs(**{name: struct_view(self._out, name, n) for name in field_names(Outputs)})
        self.inputs.pressure_meas_kpa[:] = np.nan
        # one tick, all fingers: a C-level partial, so the call adds no Python frame
        self.step = functools.partial(lib.rtcore_hand_step, self._hand, self._in, self._out)

    def configure(self, config: HandConfig) -> None:
        """Validate and apply a configuration; resets every finger. Same finger count only."""
        if hasattr(self, "inputs") and config.n_fingers != self.config.n_fingers:
            raise ConfigError("reconfigure keeps the finger count; make a new Hand instead")
        code = lib.rtcore_hand_configure(self._hand, to_c_config(config))
        if code != lib.RTCORE_OK:
            raise ConfigError(error_message(code, self._hand.error_finger))
        self.config = config

    def reset(self) -> None:
        lib.rtcore_hand_reset(self._hand)

    def reset_finger(self, finger: int) -> None:
        lib.rtcore_finger_reset(self._hand, finger)

    @property
    def c_hand(self) -> object:
        """The rtcore_hand struct (cdata pointer)."""
        return self._hand

    @property
    def c_inputs(self) -> object:
        """The rtcore_inputs struct (cdata pointer), for other C calls on the same tick."""
        return self._in

    @property
    def c_outputs(self) -> object:
        """The rtcore_outputs struct (cdata pointer)."""
        return self._out

    @property
    def ticks(self) -> int:
        return int(self._hand.ticks)

    def integrator_kpa(self, finger: int) -> float:
        return float(self._hand.finger[finger].integrator_kpa)


def butter_design(order: int, cutoff_hz: float, sample_rate_hz: float) -> np.ndarray:
    """The C core's Butterworth sections, in scipy's (n_sections, 6) sos layout."""
    sos = np.zeros((lib.RTCORE_MAX_SECTIONS, 6))
    n = lib.rtcore_butter_design(order, cutoff_hz, sample_rate_hz,
                                 ffi.cast("double *", sos.ctypes.data), lib.RTCORE_MAX_SECTIONS)
    if n < 0:
        raise ConfigError(error_message(n, -1))
    return sos[:n].copy()
