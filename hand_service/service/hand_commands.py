"""The supervisor's commands and snapshots on the structs its tick runs on: the trajectory's
place, modes with their settings, targets, recording, status and timing (surface.py says
what each does). service/supervisor.py adds the state machine and the loop."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.service.recorder import Recorder
from hand_service.service.safety import FaultLog
from hand_service.service.states import ACTIVE
from hand_service.service.status import finger_status, transport_status
from hand_service.service.surface import (
    FaultHistory,
    FaultSummary,
    GcStatus,
    Status,
    TickLoop,
    TrajectoryStatus,
)
from hand_service.service.timing import GcControl, TickStats
from hand_service.service.trajectory import Trajectory
from hand_service.transports import Transport
from rtcore import MODE_FORCE, MODE_IMPEDANCE, MODE_POSITION, MODE_PRESSURE, Hand
from rtcore.tick import Targets, Tick

TARGET_MODES = {"angle_deg": MODE_POSITION, "force_n": MODE_FORCE, "pressure_kpa": MODE_PRESSURE}


class HandCommands(TickLoop):
    """The commands and snapshots; the attributes are the supervisor's."""

    hand: Hand
    targets: Targets
    sent_kpa: np.ndarray
    recorder: Recorder
    faults: FaultLog
    stats: TickStats
    gc: GcControl
    transport: Transport
    link_open: bool
    _ts: Tick

    @property
    def trajectory(self) -> Trajectory | None:
        """The trajectory the tick plays while RUNNING (set_trajectory)."""
        return self._ts.trajectory

    @property
    def trajectory_loop(self) -> bool:
        return self._ts.loop

    @property
    def trajectory_driven(self) -> np.ndarray | None:
        """The fingers the trajectory drives (checked off the loop)."""
        return self._ts.driven

    @property
    def trajectory_tick(self) -> int:
        """The trajectory's row the next RUNNING tick plays."""
        return self._ts.trajectory_tick

    @trajectory_tick.setter
    def trajectory_tick(self, value: int) -> None:
        self._ts.trajectory_tick = value

    @property
    def trajectory_done(self) -> bool:
        """It reached its end (and did not loop): its last row is the targets, HOLD."""
        return self._ts.trajectory_done

    @trajectory_done.setter
    def trajectory_done(self, value: bool) -> None:
        self._ts.trajectory_done = value

    def trajectory_status(self) -> TrajectoryStatus | None:
        traj = self.trajectory
        if traj is None:
            return None
        return TrajectoryStatus(traj.source, traj.duration_s, self.trajectory_loop,
                                min(self.trajectory_tick, traj.n_ticks) / traj.rate_hz, self.trajectory_done)

    def trajectory_drives(self, fingers: Sequence[int]) -> list[int]:
        mask = self.trajectory_driven
        if self.trajectory is None or mask is None or (self.trajectory_done and self.state in ACTIVE):
            return []
        return [i for i in fingers if mask[i]]

    def set_mode(self, fingers: Sequence[int], mode: int,
                 gains: tuple[float, float] | None = None) -> None:
        which = list(fingers)
        if gains is not None:  # the step holds these inputs (the tick leaves them be)
            self.hand.inputs.impedance_stiffness_n_per_deg[which] = gains[0]
            self.hand.inputs.impedance_damping_n_s_per_deg[which] = gains[1]
        self.targets.mode[which] = mode

    def set_target(self, fingers: Sequence[int], quantity: str, value: float) -> list[int]:
        if quantity not in TARGET_MODES:
            raise ValueError(f"a target is one of {', '.join(TARGET_MODES)}, not {quantity!r}")
        which, targets = list(fingers), self.targets
        getattr(targets, quantity)[which] = value
        # an angle is also impedance mode's reference: a finger in impedance stays in it
        keep = (targets.mode[which] == MODE_IMPEDANCE) & (quantity == "angle_deg")
        targets.mode[which] = np.where(keep, MODE_IMPEDANCE, TARGET_MODES[quantity])
        return [int(m) for m in targets.mode[which]]

    # -- recording and status ------------------------------------------------------------
    def start_recording(self, path: Path, metadata: dict[str, object]) -> dict[str, object]:
        self.recorder.start(path, metadata)
        return self.recorder.status()

    def stop_recording(self) -> dict[str, object] | None:
        return self.recorder.stop() if self.recorder.active else None

    def status(self) -> Status:
        log_ = self.faults
        return Status(
            state=self.state, t_s=self.t_s, tick=self.tick_index, rate_hz=self.rate_hz,
            fingers=finger_status(self.names, self.hand, self.targets, self.sent_kpa),
            timing=self.stats.summary(last=int(10 * self.rate_hz)),
            faults=FaultSummary(dict(log_.counts), log_.total,
                                log_.faults[-1].as_dict() if log_.faults else None),
            trajectory=self.trajectory_status(), recording=self.recorder.status(),
            transport=transport_status(self.transport, self.link_open),
            gc=GcStatus(self.gc.collections, self.gc.collect_ns_max))

    def fault_history(self) -> FaultHistory:
        return FaultHistory(dict(self.faults.counts), self.faults.total, tuple(self.faults.faults))

    @property
    def ticks_run(self) -> int:
        return self.stats.ticks

    def timing(self, last: int | None = None) -> dict[str, Any]:
        return self.stats.summary(last=last)

    def reset_timing(self) -> None:
        self.stats = TickStats(self.period_ns)

    def summary(self) -> dict[str, Any]:
        figures = self.stats.summary()
        figures.update(state=self.state.name, stop_reason=self.stop_reason,
                       faults=dict(self.faults.counts), gc_collections=self.gc.collections,
                       gc_collect_ns_max=self.gc.collect_ns_max)
        return figures
