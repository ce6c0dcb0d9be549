"""The supervisor: one tick per deadline of an absolute schedule that never drifts.

A tick reads the newest sensor frame, fills the references for the current state, runs
the C control step for the whole hand, lets the safety gate check inputs and outputs,
sends the valve commands (or vents), and pushes one row to the recording ring. The
control API, the status line, the watchdog and the garbage collector run in the slack
after the tick, in the same thread: nothing else ever holds the GIL.
"""

from __future__ import annotations

import contextlib
import logging
import signal
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import rtcore
from hand_service.profile import Profile
from hand_service.recorder import Recorder
from hand_service.safety import Cause, Fault, FaultLog, SafetyGate
from hand_service.states import ACTIVE, LATCHED, Event, State, StateMachine
from hand_service.timing import GcControl, TickStats
from hand_service.trajectory import NOT_DRIVEN, Trajectory
from hand_service.transports import FirmwareStatus, HandshakeError, Transport
from rtcore import MODE_FORCE, MODE_POSITION, MODE_VENT, clock

log = logging.getLogger(__name__)


@dataclass
class Targets:
    """What the API asked of each finger (used when no trajectory drives it)."""

    mode: np.ndarray
    angle_deg: np.ndarray
    force_n: np.ndarray
    pressure_kpa: np.ndarray

    @classmethod
    def vented(cls, n: int) -> Targets:
        return cls(np.full(n, MODE_VENT, dtype=np.int32), np.zeros(n), np.zeros(n), np.zeros(n))


class Supervisor:
    def __init__(self, profile: Profile, transport: Transport, recorder: Recorder | None = None,
                 spin_us: float = 0.0) -> None:
        self.profile = profile
        self.transport = transport
        self.names = profile.finger_names
        n = len(self.names)
        self.rate_hz = float(profile.control["rate_hz"])
        self.period_ns = round(1e9 / self.rate_hz)
        self.spin_ns = int(spin_us * 1000)
        self.hand = rtcore.Hand(profile.hand_config())
        self.faults = FaultLog()
        self.machine = StateMachine()
        self.stats = TickStats(self.period_ns)
        self.gc = GcControl(self.rate_hz)
        self.recorder = recorder or Recorder(self.names, self.rate_hz)
        self.targets = Targets.vented(n)
        self.trajectory: Trajectory | None = None
        self.trajectory_tick = 0
        self.trajectory_done = False
        self.trajectory_loop = False
        self._driven: np.ndarray | None = None  # None: every finger follows the trajectory
        self.trajectory_driven: np.ndarray | None = None  # the fingers it drives (checked off the loop)
        self.firmware: FirmwareStatus | None = None
        self.link_open = False
        self.schedule: clock.Schedule | None = None
        self.slack: list[Callable[[int], None]] = []  # each gets the ns left before the deadline
        self.stop_reason: str | None = None
        self.tick_index = 0
        self.t_s = 0.0
        self.sent_kpa = np.zeros(n)
        self.gate = SafetyGate(profile, self.hand, self.sent_kpa)
        self.recorder.bind(self.hand.c_inputs, self.hand.c_outputs, self.sent_kpa)
        self._zeros = np.zeros(n)
        self._last_missed = False
        self._latched_causes: set[Cause] = set()
        self.on_fault: list[Callable[[Fault], None]] = []
        self.on_state: list[Callable[[State], None]] = []

    # -- state changes -----------------------------------------------------------------
    @property
    def state(self) -> State:
        return self.machine.state

    def fire(self, event: Event) -> State:
        before = self.machine.state
        after = self.machine.fire(event)
        if after is not before:
            log.info("%s -> %s (%s)", before.name, after.name, event.value)
            if after is State.INIT:
                self._latched_causes.clear()
            if event is Event.START:  # ARMED -> RUNNING: a trajectory plays from its start
                self.trajectory_tick, self.trajectory_done = 0, False
            for callback in self.on_state:
                callback(after)
        return after

    def fault(self, fault: Fault) -> None:
        """Latch FAULT (vents at once), log and count the cause, flush the recording."""
        if self.state in LATCHED and fault.cause in self._latched_causes:
            return  # the same cause, still there: logged once per latch
        self._latched_causes.add(fault.cause)
        self.faults.add(fault, self.t_s)
        where = f" [{fault.finger}]" if fault.finger else ""
        log.error("FAULT %s%s at t=%.3f s: %s", fault.cause.value, where, self.t_s, fault.detail)
        if self.machine.accepts(Event.FAULT):
            self.fire(Event.FAULT)
        self.recorder.flush()
        for callback in self.on_fault:
            callback(fault)

    def handshake(self) -> None:
        """INIT: open the transport and shake hands; DISARMED on success, FAULT if not."""
        try:
            self.firmware = self.transport.open()
        except (HandshakeError, OSError) as exc:
            self.fault(Fault(Cause.HANDSHAKE_FAILED, str(exc) or type(exc).__name__))
            return
        self.link_open = True
        log.info("handshake ok: firmware %s, protocol %d", self.firmware.firmware_version,
                 self.firmware.protocol_version)
        self.gate.reset()
        self.hand.reset()
        self.fire(Event.HANDSHAKE_OK)

    def reset(self) -> None:
        """FAULT or ESTOP -> INIT; the next tick shakes hands again."""
        self.fire(Event.RESET)
        self._close_link()

    def _close_link(self) -> None:
        if not self.link_open:
            return
        self.link_open = False
        try:
            self.transport.close()
        except Exception as exc:
            log.warning("closing the transport: %s: %s", type(exc).__name__, exc)

    # -- references --------------------------------------------------------------------
    def _references(self, state: State) -> None:
        inputs = self.hand.inputs
        if state not in ACTIVE:
            inputs.mode[:] = MODE_VENT
            return
        if state is State.HOLD:
            inputs.velocity_ref_deg_per_s[:] = 0.0
            inputs.accel_ref_deg_per_s2[:] = 0.0
            inputs.jerk_ref_deg_per_s3[:] = 0.0
            return
        traj = self.trajectory
        if traj is None or self.trajectory_done:
            self._targets_to_inputs()
            return
        k = self.trajectory_tick
        if k >= traj.n_ticks:
            if self.trajectory_loop:
                k = self.trajectory_tick = k % traj.n_ticks
            else:
                self._finish_trajectory(traj)
                return
        driven = self._driven
        if driven is None:  # every finger follows the trajectory: whole rows
            inputs.mode[:] = traj.mode[k]
            inputs.angle_ref_deg[:] = traj.angle_deg[k]
            inputs.velocity_ref_deg_per_s[:] = traj.velocity_deg_per_s[k]
            inputs.accel_ref_deg_per_s2[:] = traj.accel_deg_per_s2[k]
            inputs.jerk_ref_deg_per_s3[:] = traj.jerk_deg_per_s3[k]
            inputs.force_ref_n[:] = traj.force_n[k]
            return
        self._targets_to_inputs()
        np.copyto(inputs.mode, traj.mode[k], where=driven)
        np.copyto(inputs.angle_ref_deg, traj.angle_deg[k], where=driven)
        np.copyto(inputs.velocity_ref_deg_per_s, traj.velocity_deg_per_s[k], where=driven)
        np.copyto(inputs.accel_ref_deg_per_s2, traj.accel_deg_per_s2[k], where=driven)
        np.copyto(inputs.jerk_ref_deg_per_s3, traj.jerk_deg_per_s3[k], where=driven)
        np.copyto(inputs.force_ref_n, traj.force_n[k], where=driven)

    def _targets_to_inputs(self) -> None:
        inputs, targets = self.hand.inputs, self.targets
        inputs.mode[:] = targets.mode
        inputs.angle_ref_deg[:] = targets.angle_deg
        inputs.velocity_ref_deg_per_s[:] = 0.0
        inputs.accel_ref_deg_per_s2[:] = 0.0
        inputs.jerk_ref_deg_per_s3[:] = 0.0
        inputs.force_ref_n[:] = targets.force_n
        inputs.pressure_ref_kpa[:] = targets.pressure_kpa

    @staticmethod
    def check_trajectory(traj: Trajectory) -> np.ndarray:
        """Which fingers traj drives; a ValueError unless it drives each at every tick or never."""
        driven = traj.driven()
        if ((traj.mode == NOT_DRIVEN) != ~driven).any():
            raise ValueError("a trajectory drives a finger at every tick or never")
        return driven

    def set_trajectory(self, traj: Trajectory | None, loop: bool = False,
                       driven: np.ndarray | None = None) -> None:
        """Follow `traj` from its start when RUNNING (and from its start again at every
        `start`; `resume` after `hold` continues where it paused). A finger it drives
        follows it at every tick; the others keep their API targets. `driven`: what
        check_trajectory returned already (off the loop: checking an hour of trajectory
        takes milliseconds)."""
        if traj is not None and driven is None:
            driven = self.check_trajectory(traj)
        self.trajectory, self.trajectory_tick = traj, 0
        self.trajectory_done, self.trajectory_loop = False, loop
        self.trajectory_driven = driven
        self._driven = None if driven is None or driven.all() else driven

    def _finish_trajectory(self, traj: Trajectory) -> None:
        """The end holds the last references: they become the fingers' targets, HOLD."""
        last = traj.n_ticks - 1
        assert self.trajectory_driven is not None
        for i in np.flatnonzero(self.trajectory_driven):
            mode = int(traj.mode[last, i])
            self.targets.mode[i] = mode
            if mode == MODE_POSITION:
                self.targets.angle_deg[i] = traj.angle_deg[last, i]
            elif mode == MODE_FORCE:
                self.targets.force_n[i] = traj.force_n[last, i]
        self.trajectory_done = True
        log.info("trajectory %s finished after %.2f s", traj.source, traj.duration_s)
        self._references(State.RUNNING)
        self.fire(Event.HOLD)

    # -- the tick ------------------------------------------------------------------------
    def tick(self, woke_ns: int) -> None:
        state = self.machine.state
        if state is State.INIT:
            self.handshake()
            self._vent_and_record(self.machine.state)
            return
        fault = self.gate.overrun(self._last_missed)
        inputs, outputs = self.hand.inputs, self.hand.outputs
        try:
            self.transport.on_tick(self.tick_index)
            sample = self.transport.latest()
            status = self.transport.status()
        except Exception as exc:  # any failure of the link is a lost transport
            sample, status = None, None
            fault = fault or Fault(Cause.TRANSPORT_LOST, f"latest(): {type(exc).__name__}: {exc}")
        fresh = sample is not None
        if fresh:
            inputs.sensor_mv[:] = sample.sensor_mv
            inputs.pressure_meas_kpa[:] = sample.pressure_meas_kpa
            fault = fault or self.gate.sample()
        fault = fault or self.gate.frame(sample, woke_ns)
        if status is not None:
            fault = fault or self.gate.firmware(status, state in ACTIVE)
        self._references(state)
        if state is State.RUNNING and self.trajectory is not None and not self.trajectory_done:
            self.trajectory_tick += 1
        self.hand.step()
        fault = fault or self.gate.outputs()
        if fault is not None:
            self.fault(fault)
        vented = self.machine.vented
        sent = self._zeros if vented else outputs.pressure_cmd_kpa
        try:
            if vented:
                self.transport.vent()
            else:
                self.transport.send(sent)
        except Exception as exc:
            # a command the wire cannot carry (ValueError: the gate should have caught it), or
            # a link that failed: either way nothing went out this tick, so ask for a vent
            cause = Cause.PRESSURE_OVER_LIMIT if isinstance(exc, ValueError) else Cause.TRANSPORT_LOST
            self.fault(Fault(cause, f"send(): {type(exc).__name__}: {exc}"))
            with contextlib.suppress(Exception):
                self.transport.vent()
            sent = self._zeros
        self.sent_kpa[:] = sent
        leak = self.gate.follow()
        if leak is not None:
            self.fault(leak)
        self._record(self.machine.state)

    def _vent_and_record(self, state: State) -> None:
        """A tick without control (INIT, shutdown): vent, record zeros."""
        self.hand.inputs.mode[:] = MODE_VENT
        if self.link_open:
            try:
                self.transport.vent()
            except Exception as exc:
                log.warning("venting: %s: %s", type(exc).__name__, exc)
        self.sent_kpa[:] = 0.0
        self._record(state)

    def _record(self, state: State) -> None:
        # one C call builds the row from the step's structs and sent_kpa (the writer blanks
        # the references a finger's mode does not use)
        self.recorder.push_tick(self.t_s, state)

    # -- the loop -------------------------------------------------------------------------
    def request_stop(self, reason: str) -> None:
        if self.stop_reason is None:
            self.stop_reason = reason
            self.recorder.flush()

    def install_signal_handlers(self) -> None:
        def handler(signum: int, _frame: object) -> None:
            self.request_stop(signal.Signals(signum).name)
        signal.signal(signal.SIGTERM, handler)
        signal.signal(signal.SIGINT, handler)

    def run(self, duration_s: float | None = None, max_ticks: int | None = None) -> None:
        """Tick on the absolute schedule until a stop request, duration_s or max_ticks."""
        self.gc.start()  # a full collection and a freeze: before the schedule starts, not in its first period
        self.schedule = schedule = clock.Schedule(self.period_ns)
        end_index = None if duration_s is None else round(duration_s * self.rate_hz)
        try:
            while self.stop_reason is None:
                if end_index is not None and schedule.index >= end_index:
                    self.stop_reason = "duration"
                    break
                if max_ticks is not None and self.stats.ticks >= max_ticks:
                    self.stop_reason = "ticks"
                    break
                self.run_one(schedule)
        except BaseException as exc:  # a bug, or KeyboardInterrupt: vent all the same, then raise
            if self.stop_reason is None:
                self.stop_reason = f"{type(exc).__name__} in the loop"
            log.critical("the loop stopped on %s: %s", type(exc).__name__, exc)
            raise
        finally:
            self.gc.stop()
            self.shutdown()

    def run_one(self, schedule: clock.Schedule) -> None:
        """Sleep to the next deadline, tick, then the slack jobs."""
        deadline = schedule.deadline_ns
        woke = clock.sleep_until_ns(deadline, self.spin_ns)
        while woke < 0:  # a signal: its handler has run; sleep on unless told to stop
            if self.stop_reason is not None:
                return
            woke = clock.sleep_until_ns(deadline, self.spin_ns)
        self.tick_index = schedule.index
        self.t_s = schedule.index / self.rate_hz
        self.tick(woke)
        end = clock.now_ns()
        self._last_missed = self.stats.add(deadline, woke, end)
        skipped = schedule.advance(end)
        if skipped:
            self.stats.skipped += skipped
            if self.state is State.RUNNING and not self.trajectory_done:
                self.trajectory_tick += skipped
        slack_ns = schedule.deadline_ns - clock.now_ns()
        for job in self.slack:
            job(slack_ns)
        if self.recorder.closing:  # a stopped recording's writer: collect it once it is done
            self.recorder.reap()
        self.gc.maybe_collect(self.stats.ticks, schedule.deadline_ns - clock.now_ns())

    def shutdown(self) -> None:
        """Vent, record the vented tick, flush and close the recording, close the link.
        Runs however the loop ended (run()'s finally); each step runs even if one before
        it fails."""
        log.info("stopping (%s): venting", self.stop_reason)
        if self.schedule is not None:
            self.t_s = self.schedule.index / self.rate_hz  # the slot after the last tick
        self.hand.inputs.mode[:] = MODE_VENT
        for step in (self.hand.step, lambda: self._vent_and_record(self.state),
                     self.recorder.close, self._close_link):
            try:
                step()
            except Exception as exc:
                log.error("shutting down: %s: %s", type(exc).__name__, exc)


__all__ = ["Supervisor", "Targets"]
