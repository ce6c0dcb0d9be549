"""The supervisor's tick in C (rtcore_tick, csrc/rtcore_tick.c) on the Python side.

Everything a tick does between reading the sensors and sending the valve commands runs
in C on caller-owned structs: the gate's checks, the references for the supervisor's
state, the control step and the command to send. Here: the struct, the API's targets
and the sent command as numpy views into it, a trajectory bound into it by pointer, and
the calls — the two halves around a transport in Python (`control`, `follow`), or the
whole tick on the simulated link (`on_link`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.gate import Gate
from rtcore.hand import Hand, struct_view
from rtcore.sim_link import SimLink

# the references a tick feeds the step
REFS_VENT = lib.RTCORE_REFS_VENT  # every finger vents
REFS_HOLD = lib.RTCORE_REFS_HOLD  # every reference stays where it is, at rest
REFS_RUN = lib.RTCORE_REFS_RUN  # the trajectory while it plays, else the targets

# what a tick found: bits of its return value
FOUND_OVERRUN = lib.RTCORE_TICK_OVERRUN
FOUND_SAMPLE = lib.RTCORE_TICK_SAMPLE
FOUND_FRAME = lib.RTCORE_TICK_FRAME
FOUND_OUTPUT = lib.RTCORE_TICK_OUTPUT
FOUND_LEAK = lib.RTCORE_TICK_LEAK
FOUND_TRAJECTORY_END = lib.RTCORE_TICK_TRAJECTORY_END


@dataclass
class Targets:
    """What the API asked of each finger (used when no trajectory drives it): views into
    the tick struct, so a write here is what the next tick uses."""

    mode: np.ndarray
    angle_deg: np.ndarray
    force_n: np.ndarray
    pressure_kpa: np.ndarray


@dataclass(frozen=True)
class LinkTick:
    """The whole tick on the simulated link, in one C call each.

    tick(tick_index, refs, missed_last, woke_ns) -> found bits;
    tick_at(deadline_ns, spin_ns, tick_index, refs, missed_last, t_s, state, times_ns)
    also sleeps to the deadline and pushes the ring row when nothing was found, and
    returns -1 (times_ns[0] the errno) when the sleep failed; advance() simulates the
    period of the command sent last.
    """

    tick: Callable[..., int]
    tick_at: Callable[..., int]
    advance: Callable[[], object]


class Tick:
    """An rtcore_tick on a hand and a gate. The struct starts zeroed: every target is
    MODE_VENT at 0, no trajectory. `c` is the struct (a recorder publishes its ring into
    it); overrun, sample, frame, output and follow are what each check found."""

    def __init__(self, hand: Hand, gate: Gate, n_fingers: int) -> None:
        self.c = c = ffi.new("rtcore_tick *")
        c.n_fingers, c.hand, c.gate = n_fingers, hand.c_hand, gate.c_gate
        c.inputs, c.outputs = hand.c_inputs, hand.c_outputs
        self._keep = (hand, gate)  # the structs c points into
        self.n_fingers = n_fingers
        self.targets = Targets(*(struct_view(c, f"target_{name}", n_fingers)
                                 for name in ("mode", "angle_deg", "force_n", "pressure_kpa")))
        self.sent_kpa = struct_view(c, "sent_kpa", n_fingers)
        # control(refs, vent, missed_last, fresh, lost_in_a_row, woke_ns) -> found bits:
        # the tick up to the send, on the sample the caller wrote into the hand's inputs
        self.control = functools.partial(lib.rtcore_tick_control, c)
        # follow() -> FOUND_LEAK or 0: the leak-or-burst check after the send
        self.follow = functools.partial(lib.rtcore_tick_follow, c)
        self._trajectory_arrays: tuple[np.ndarray, ...] = ()
        self.trajectory: Any = None  # what the struct plays, with:
        self.loop = False
        self.driven: np.ndarray | None = None  # the fingers it drives

    # what each check found (an rtcore_gate_result: cause, finger, value, limit)
    @property
    def overrun(self) -> Any:
        return self.c.overrun

    @property
    def sample(self) -> Any:
        return self.c.sample

    @property
    def frame(self) -> Any:
        return self.c.frame

    @property
    def output(self) -> Any:
        return self.c.output

    @property
    def follow_result(self) -> Any:
        return self.c.follow

    def on_link(self, link: SimLink) -> LinkTick:
        """The whole tick on the simulated link, in C."""
        return LinkTick(functools.partial(lib.rtcore_tick_sim, self.c, link.c_link),
                        functools.partial(lib.rtcore_tick_sim_at, self.c, link.c_link),
                        link.advance)

    @staticmethod
    def times() -> Any:
        """A buffer for tick_at's wake-up and end times (ns)."""
        return ffi.new("int64_t[2]")

    def bind_trajectory(self, traj: Any, loop: bool = False, driven: np.ndarray | None = None) -> None:
        """Point the struct at traj's rows (None: no trajectory) from its first row, with
        `driven` one flag per finger. traj has n_ticks and, per tick and finger, mode,
        angle_deg, velocity_deg_per_s, accel_deg_per_s2, jerk_deg_per_s3 and force_n. The
        arrays are kept here while the struct points into them. A ValueError leaves the
        trajectory bound before as it was."""
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

    @property
    def trajectory_tick(self) -> int:
        """The row the next RUNNING tick plays."""
        return int(self.c.trajectory_tick)

    @trajectory_tick.setter
    def trajectory_tick(self, value: int) -> None:
        self.c.trajectory_tick = value

    @property
    def trajectory_done(self) -> bool:
        """Its end has been reached: the targets hold its last row."""
        return bool(self.c.trajectory_done)

    @trajectory_done.setter
    def trajectory_done(self, value: bool) -> None:
        self.c.trajectory_done = int(value)


__all__ = ["FOUND_FRAME", "FOUND_LEAK", "FOUND_OUTPUT", "FOUND_OVERRUN", "FOUND_SAMPLE",
           "FOUND_TRAJECTORY_END", "REFS_HOLD", "REFS_RUN", "REFS_VENT", "LinkTick", "Targets", "Tick"]
