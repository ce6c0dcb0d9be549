"""The supervisor's tick struct (rtcore_tick, csrc/rtcore_tick.c) on the Python side:
the API's targets and the sent command as numpy views into it, and a trajectory bound
into it by pointer, so the tick reads them in C with no conversion."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import rtcore
from hand_service.safety import SafetyGate
from hand_service.states import State
from hand_service.trajectory import Trajectory
from rtcore._rtcore import ffi, lib
from rtcore.hand import struct_view

# the references each state feeds the step, indexed by State
REFS = tuple(lib.RTCORE_REFS_RUN if state is State.RUNNING else
             lib.RTCORE_REFS_HOLD if state is State.HOLD else lib.RTCORE_REFS_VENT for state in State)


@dataclass
class Targets:
    """What the API asked of each finger (used when no trajectory drives it): views into
    the tick struct, so a write here is what the next tick uses."""

    mode: np.ndarray
    angle_deg: np.ndarray
    force_n: np.ndarray
    pressure_kpa: np.ndarray


class TickStruct:
    """An rtcore_tick on a hand and a gate. The struct starts zeroed: every target is
    MODE_VENT at 0, no trajectory."""

    def __init__(self, hand: rtcore.Hand, gate: SafetyGate, n_fingers: int) -> None:
        self.c = c = ffi.new("rtcore_tick *")
        c.n_fingers, c.hand, c.gate = n_fingers, hand.c_hand, gate.c_gate
        c.inputs, c.outputs = hand.c_inputs, hand.c_outputs
        self._keep = (hand, gate)  # the structs c points into
        self.n_fingers = n_fingers
        self.targets = Targets(*(struct_view(c, f"target_{name}", n_fingers)
                                 for name in ("mode", "angle_deg", "force_n", "pressure_kpa")))
        self.sent_kpa = struct_view(c, "sent_kpa", n_fingers)
        self._trajectory_arrays: tuple[np.ndarray, ...] = ()
        self.trajectory: Trajectory | None = None  # what the struct plays, with:
        self.loop = False
        self.driven: np.ndarray | None = None  # the fingers it drives

    def bind_trajectory(self, traj: Trajectory | None, loop: bool = False,
                        driven: np.ndarray | None = None) -> None:
        """Point the struct at traj's rows (None: no trajectory) from its first row, with
        `driven` one flag per finger. The arrays are kept here while the struct points into
        them. A ValueError leaves the trajectory bound before as it was."""
        arrays: tuple[np.ndarray, ...] = ()
        if traj is not None:
            shape = (traj.n_ticks, self.n_fingers)
            arrays = (np.ascontiguousarray(traj.mode, dtype=np.int32),
                      *(np.ascontiguousarray(a, dtype=np.float64) for a in
                        (traj.angle_deg, traj.velocity_deg_per_s, traj.accel_deg_per_s2,
                         traj.jerk_deg_per_s3, traj.force_n)))
            if any(a.shape != shape for a in arrays):
                raise ValueError(f"a trajectory for this hand has {shape[1]} columns per quantity")
            if driven is None or np.shape(driven) != (self.n_fingers,):
                raise ValueError("which fingers the trajectory drives: one flag per finger")
        c = self.c.trajectory
        c.n_ticks = 0  # no trajectory while the pointers change
        self.c.trajectory_tick, self.c.trajectory_done = 0, 0
        self._trajectory_arrays = arrays
        self.trajectory, self.loop = traj, loop
        self.driven = None if traj is None else driven
        if traj is None or driven is None:
            return
        c.mode = ffi.cast("int32_t *", ffi.from_buffer(arrays[0]))
        c.angle_deg, c.velocity_deg_per_s, c.accel_deg_per_s2, c.jerk_deg_per_s3, c.force_n = (
            ffi.cast("double *", ffi.from_buffer(a)) for a in arrays[1:])
        c.loop = int(loop)
        for i in range(self.n_fingers):
            c.driven[i] = int(driven[i])
        c.n_ticks = traj.n_ticks


__all__ = ["REFS", "Targets", "TickStruct"]
