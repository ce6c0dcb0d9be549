"""The supervisor's command surface: the one way in for the control API, the benchmark, the
demo and the daemon's wiring.

As python-can's BusABC keeps a bus to a few abstract methods, `HandControl` is what a
client may ask of the hand (the state machine's events, modes with their settings, targets,
trajectories, recording, a status snapshot) and `TickLoop` adds how the loop is driven
(run, one tick, the slack, timing). service/supervisor.py implements both; nothing outside
service/ and the wiring (app/daemon.py) names it (tests/test_supervisor_surface.py).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.config.profile import Profile
from hand_service.service.safety import Fault
from hand_service.service.states import Event, State
from hand_service.service.trajectory import Trajectory
from rtcore import clock

# what a target sets, and the mode it puts the finger in (an angle keeps impedance mode)
TARGET_QUANTITIES = ("angle_deg", "force_n", "pressure_kpa")


@dataclass(frozen=True)
class FingerStatus:
    mode: str  # the mode the step ran in
    target_mode: str  # the mode the API asked for
    angle_deg: float
    angle_filt_deg: float
    angle_ref_deg: float | None  # in position and impedance mode
    force_ref_n: float | None  # in force mode
    pressure_cmd_kpa: float
    pressure_meas_kpa: float | None  # None where the board does not report it
    force_est_n: float  # signed, like force_ref_n
    flags: list[str]


@dataclass(frozen=True)
class TrajectoryStatus:
    source: str
    duration_s: float
    loop: bool
    t_s: float  # where it is
    done: bool  # reached its end (and did not loop): its last row holds


@dataclass(frozen=True)
class FirmwareSummary:
    protocol_version: int
    firmware_version: str
    vented: bool
    fault_code: int
    fault_text: str


@dataclass(frozen=True)
class TransportStatus:
    kind: str
    open: bool
    health: dict[str, int] | None  # None while the link is closed
    firmware: FirmwareSummary | None
    # what the link's checks estimate (Transport.link_estimates: round_trip_ms, clock_drift_ppm,
    # ...), None where not known yet; empty for a link without such checks
    link: dict[str, float | None] = field(default_factory=dict)


@dataclass(frozen=True)
class FaultSummary:
    counts: dict[str, int]
    total: int
    last: dict[str, object] | None


@dataclass(frozen=True)
class FaultHistory:
    counts: dict[str, int]
    total: int
    faults: tuple[Fault, ...]  # oldest first, as many as the log keeps


@dataclass(frozen=True)
class GcStatus:
    collections: int
    collect_ns_max: int


@dataclass(frozen=True)
class Status:
    """A snapshot of the supervisor between two ticks."""

    state: State
    t_s: float
    tick: int
    rate_hz: float
    fingers: dict[str, FingerStatus]
    timing: dict[str, Any]  # TickStats.summary over the last 10 s
    faults: FaultSummary
    trajectory: TrajectoryStatus | None
    recording: dict[str, object]  # Recorder.status
    transport: TransportStatus
    gc: GcStatus

    def as_dict(self) -> dict[str, Any]:
        """As JSON takes it: the state by name."""
        snapshot = asdict(self)
        snapshot["state"] = self.state.name
        return snapshot


class HandControl(ABC):
    """What a client may ask of the hand. Each call runs between two ticks."""

    profile: Profile
    names: list[str]  # the fingers, in the profile's order
    rate_hz: float
    period_ns: int

    # -- the state machine (service/states.py) ---------------------------------------------
    @property
    @abstractmethod
    def state(self) -> State: ...

    @abstractmethod
    def fire(self, event: Event) -> State:
        """Take the transition, or a TransitionError saying what would."""

    @abstractmethod
    def reset(self) -> State:
        """FAULT or ESTOP -> INIT (the link closes; the next tick shakes hands again)."""

    def arm(self) -> State:
        return self.fire(Event.ARM)

    def disarm(self) -> State:
        return self.fire(Event.DISARM)

    def start(self) -> State:
        return self.fire(Event.START)

    def hold(self) -> State:
        return self.fire(Event.HOLD)

    def resume(self) -> State:
        return self.fire(Event.RESUME)

    def estop(self) -> State:
        return self.fire(Event.ESTOP)

    # -- what the fingers follow -----------------------------------------------------------
    @abstractmethod
    def set_mode(self, fingers: Sequence[int], mode: int,
                 gains: tuple[float, float] | None = None) -> None:
        """Put `fingers` in `mode` (rtcore MODE_*); `gains`: impedance mode's stiffness
        (N/deg) and damping (N s/deg), checked by the caller (api/impedance.py)."""

    @abstractmethod
    def set_target(self, fingers: Sequence[int], quantity: str, value: float) -> list[int]:
        """Set one of TARGET_QUANTITIES for `fingers` (checked by the caller against the
        profile) and the mode it implies; the fingers' modes after."""

    @abstractmethod
    def set_trajectory(self, traj: Trajectory | None, loop: bool = False,
                       driven: np.ndarray | None = None) -> None:
        """Follow `traj` from its start when RUNNING; None: no trajectory. `driven`: the
        fingers it drives (trajectory.driven_fingers), when already known."""

    def clear_trajectory(self) -> None:
        self.set_trajectory(None)

    @abstractmethod
    def trajectory_status(self) -> TrajectoryStatus | None: ...

    @abstractmethod
    def trajectory_drives(self, fingers: Sequence[int]) -> list[int]:
        """Those of `fingers` whose modes and targets the trajectory sets: while it plays
        (RUNNING or HOLD, not done), and in any other state while one is loaded (the next
        `start` plays it from its start)."""

    # -- recording ---------------------------------------------------------------------------
    @abstractmethod
    def start_recording(self, path: Path, metadata: dict[str, object]) -> dict[str, object]:
        """Record every tick to a new CSV at `path`; the recording's status."""

    @abstractmethod
    def stop_recording(self) -> dict[str, object] | None:
        """Close the recording: what it wrote, or None when none was active."""

    # -- what it is doing ----------------------------------------------------------------------
    @abstractmethod
    def status(self) -> Status: ...

    @abstractmethod
    def fault_history(self) -> FaultHistory: ...


class TickLoop(HandControl):
    """The hand, and the loop that ticks it on an absolute schedule."""

    stop_reason: str | None  # why the loop stopped (or is stopping), None while it runs
    tick_index: int  # the schedule's index of the tick last run
    t_s: float  # its time on the schedule

    @abstractmethod
    def run(self, duration_s: float | None = None, max_ticks: int | None = None) -> None:
        """Tick until a stop request, duration_s or max_ticks; shut down however it ends."""

    @abstractmethod
    def run_one(self, schedule: clock.Schedule) -> None:
        """Sleep to the schedule's next deadline, tick, then the slack jobs."""

    @abstractmethod
    def stepping(self, reason: str) -> AbstractContextManager[None]:
        """For a caller that calls run_one itself: the garbage collector kept out of the
        ticks inside; at the exit, stop for `reason` and shut down (vent, close)."""

    @abstractmethod
    def request_stop(self, reason: str) -> None: ...

    @abstractmethod
    def shutdown(self) -> None:
        """Vent, record the vented tick, close the recording and the link."""

    @abstractmethod
    def install_signal_handlers(self) -> None:
        """SIGTERM and SIGINT request a stop."""

    @abstractmethod
    def add_slack(self, job: Callable[[int], None], first: bool = False) -> None:
        """Run job(ns left before the next deadline) after every tick."""

    @abstractmethod
    def on_state_change(self, callback: Callable[[State], None]) -> None: ...

    @property
    @abstractmethod
    def next_tick_index(self) -> int:
        """The schedule's index of the next tick (more than one on after a skipped deadline)."""

    @property
    @abstractmethod
    def ticks_run(self) -> int:
        """Ticks run since the timing was last reset."""

    @abstractmethod
    def timing(self, last: int | None = None) -> dict[str, Any]:
        """Tick duration, jitter and misses over the last `last` ticks (default: all kept)."""

    @abstractmethod
    def reset_timing(self) -> None:
        """Count the timing from the next tick on (a benchmark's settling left out)."""

    @abstractmethod
    def time_hand_advance(self) -> list[int] | None:
        """From now on, the ns each slack spends simulating the hand's period, appended to
        the list returned; None when no hand is simulated in this process."""

    @abstractmethod
    def summary(self) -> dict[str, Any]:
        """The run's figures once it stopped: timing, state, stop reason, faults, gc."""
