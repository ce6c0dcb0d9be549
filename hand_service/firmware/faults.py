"""Faults the mock firmware injects on request from its debug port (FaultRequest).

Link faults act on the frames (or framed bytes) leaving the board: drop, delay, corrupt,
silence, bus-off (nothing crosses either way). Sensor faults act on the readings: stuck,
out of range, NaN flex sensor, NaN or frozen chamber pressure. The rest (a reboot, a fault
of the board's own, valves that ignore commands, a protocol change, a stuck sample
sequence, CAN error frames, a drifting clock) are the firmware's own doing (mock.py).
Every fault but a reboot lasts `duration_ms` (0: until a clear).
"""

from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass
from typing import Any

import can
import numpy as np

from hand_service.wire.messages import ALL_FINGERS, FaultKind, FaultRequest

OPEN_CIRCUIT_MV = 65535.0  # the default out-of-range reading: clipped to what the wire carries


@dataclass
class ActiveFault:
    request: FaultRequest
    until_s: float
    held: np.ndarray | None = None  # STUCK_SENSOR, PRESSURE_STUCK: the readings it froze

    def freeze(self, values: np.ndarray, n: int) -> None:
        """Its fingers' values as they were when it began (kept from the first call)."""
        if self.held is None:
            self.held = values.copy()
        for i in self.fingers(n):
            values[i] = self.held[i]

    def fingers(self, n: int) -> list[int]:
        index = self.request.finger_index
        return list(range(n)) if index == ALL_FINGERS else [index] if index < n else []


def corrupt(unit: Any, rng: random.Random) -> Any:
    """The same frame with one bit flipped: a CAN payload, or a framed byte string."""
    data = bytearray(unit.data if isinstance(unit, can.Message) else unit)
    if not data:
        return unit
    data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    if isinstance(unit, can.Message):
        return can.Message(arbitration_id=unit.arbitration_id, is_extended_id=unit.is_extended_id,
                           data=data)
    return bytes(data)


class FaultInjector:
    def __init__(self, n_fingers: int, seed: int) -> None:
        self.n_fingers = n_fingers
        self.rng = random.Random(seed)
        self.active: dict[FaultKind, ActiveFault] = {}
        self.held: deque[tuple[float, Any]] = deque()  # DELAY: (release time, unit)

    def request(self, request: FaultRequest, now: float) -> None:
        if request.kind == FaultKind.CLEAR:
            self.active.clear()
            return
        until = now + request.duration_ms / 1e3 if request.duration_ms else math.inf
        self.active[request.kind] = ActiveFault(request, until)

    def clear(self) -> None:
        self.active.clear()
        self.held.clear()

    @property
    def current(self) -> FaultKind:
        return next(reversed(self.active), FaultKind.CLEAR)

    def expire(self, now: float) -> list[FaultKind]:
        ended = [kind for kind, fault in self.active.items() if now >= fault.until_s]
        for kind in ended:
            del self.active[kind]
        return ended

    def _percent(self, kind: FaultKind) -> bool:
        fault = self.active.get(kind)
        return fault is not None and self.rng.random() * 100.0 < fault.request.value

    def outgoing(self, units: list[Any], now: float) -> list[Any]:
        """What leaves the board now; delayed units come back from release()."""
        if FaultKind.SILENCE in self.active or FaultKind.BUS_OFF in self.active:
            return []
        out = [corrupt(u, self.rng) if self._percent(FaultKind.CORRUPT) else u
               for u in units if not self._percent(FaultKind.DROP)]
        delay = self.active.get(FaultKind.DELAY)
        if delay is not None or self.held:  # first in, first out: nothing overtakes a held frame
            due = now + (delay.request.value / 1e3 if delay else 0.0)
            due = max(due, self.held[-1][0]) if self.held else due
            self.held.extend((due, u) for u in out)
            return []
        return out

    def next_release_s(self) -> float | None:
        return self.held[0][0] if self.held else None

    def release(self, now: float) -> list[Any]:
        out = []
        while self.held and self.held[0][0] <= now:
            out.append(self.held.popleft()[1])
        return out

    def sensors(self, sensor_mv: np.ndarray) -> np.ndarray:
        """The readings as the faulty sensors report them."""
        stuck = self.active.get(FaultKind.STUCK_SENSOR)
        if stuck is not None:
            stuck.freeze(sensor_mv, self.n_fingers)
        wild = self.active.get(FaultKind.SENSOR_OUT_OF_RANGE)
        if wild is not None:
            for i in wild.fingers(self.n_fingers):
                sensor_mv[i] = wild.request.value or OPEN_CIRCUIT_MV
        nan = self.active.get(FaultKind.SENSOR_NAN)
        if nan is not None:
            sensor_mv[nan.fingers(self.n_fingers)] = math.nan
        return sensor_mv

    def pressures(self, pressure_kpa: np.ndarray) -> np.ndarray:
        """The chamber pressures as the faulty pressure sensors report them."""
        stuck = self.active.get(FaultKind.PRESSURE_STUCK)
        if stuck is not None:
            stuck.freeze(pressure_kpa, self.n_fingers)
        nan = self.active.get(FaultKind.PRESSURE_NAN)
        if nan is not None:
            pressure_kpa[nan.fingers(self.n_fingers)] = math.nan
        return pressure_kpa

    def value(self, kind: FaultKind, default: int = 0) -> int | None:
        """The active fault's `value` (its default for 0), or None when it is not active."""
        fault = self.active.get(kind)
        return None if fault is None else fault.request.value or default
