"""The supervisor: one tick per deadline of an absolute schedule that never drifts.

A tick reads the newest sensor frame, lets the safety gate check it, fills the
references for the current state, runs the C control step for the whole hand, lets the
gate check its outputs, sends the valve commands (or vents), and pushes one row to the
recording ring. Everything between the sensors and the valves is one C call
(csrc/rtcore_tick.c); on the simulated hand the sensors, the valves, the sleep before
and the ring row after are too, so no Python runs from the wake-up to the end of a tick
that finds nothing. Python keeps the state machine, the transports of a bus and
the wording of a fault. The control API, the status line, the watchdog, the simulated
hand's physics and the garbage collector run in the slack after the tick, in the same
thread: nothing else ever holds the GIL."""

from __future__ import annotations

import contextlib
import logging
import signal
import time
from collections.abc import Callable, Iterator

import numpy as np

import rtcore
from hand_service.config.profile import Profile
from hand_service.service.bus_tick import BusTickPath, PythonTickPath
from hand_service.service.hand_commands import HandCommands
from hand_service.service.recorder import SHUTDOWN_STATE, Recorder
from hand_service.service.safety import Cause, Fault, FaultLog, SafetyGate
from hand_service.service.states import ACTIVE, LATCHED, Event, State, StateMachine
from hand_service.service.tick_path import CoreTickPath, TickPath, sleep_to
from hand_service.service.timing import GcControl, TickStats
from hand_service.service.trajectory import Trajectory
from hand_service.transports import FirmwareStatus, HandshakeError, Transport
from hand_service.transports.in_c import BusTickInC, HandInProcess
from rtcore import MODE_VENT, clock
from rtcore.tick import FOUND_LEAK, FOUND_TRAJECTORY_END, Tick

log = logging.getLogger(__name__)


class Supervisor(HandCommands):
    """The state machine and the loop behind the command surface (surface.TickLoop); made
    through service/factory.py by everything above the service."""

    def __init__(self, profile: Profile, transport: Transport, recorder: Recorder | None = None,
                 spin_us: float = 0.0) -> None:
        self.profile = profile
        self.transport = transport
        self.names = profile.finger_names
        n = len(self.names)
        self.rate_hz = float(profile.control.rate_hz)
        self.period_ns = round(1e9 / self.rate_hz)
        self.spin_ns = int(spin_us * 1000)
        self.hand = rtcore.Hand(profile.hand_config())
        self.gate = SafetyGate(profile)
        self.model_check = self.gate.model_check
        # the tick between sensors and valves in C (csrc/rtcore_tick.c)
        self._ts = Tick(self.hand, self.gate.core, n)
        self.faults = FaultLog()
        self.machine = StateMachine()
        self.stats = TickStats(self.period_ns)
        self.gc = GcControl(self.rate_hz)
        self.recorder = recorder or Recorder(self.names, self.rate_hz)
        self.targets = self._ts.targets
        self.firmware: FirmwareStatus | None = None
        self.link_open = False
        self.schedule: clock.Schedule | None = None
        self.slack: list[Callable[[int], None]] = []  # each gets the ns left before the deadline
        self.stop_reason: str | None = None
        self.tick_index = 0
        self.t_s = 0.0
        self.sent_kpa = self._ts.sent_kpa
        self.missed_last = False  # the tick before missed its deadline
        self.path = self._choose_path()
        # tests/hil/matrix.py times the vents the C tick over can-v1 encodes through this
        self._bus_tick = self.path.bus if isinstance(self.path, BusTickPath) else None
        # the recording's rows; on the simulated hand with its true angle (the sample's)
        link = self.path.link
        truth = None if link is None else link.simulator.c_outputs.angle_deg
        self.recorder.bind(self.hand.c_inputs, self.hand.c_outputs, self.sent_kpa, self._ts.c, truth)
        self._latched_causes: set[Cause] = set()
        self.on_fault: list[Callable[[Fault], None]] = []
        self.on_state: list[Callable[[State], None]] = []

    def _choose_path(self) -> TickPath:
        """How the tick reaches the hand, once: on the in-process simulated hand the whole
        tick, sensors to valves, is one C call (and on the schedule the sleep, that tick and
        its ring row); over can-v1 decoding, control and encoding are; else the transport in
        Python around the C control and follow halves (service/tick_path.py)."""
        transport = self.transport
        link = transport.core_link() if isinstance(transport, HandInProcess) else None
        if link is not None:
            return CoreTickPath(self, self._ts, link)
        bus = transport.bus_tick(self._ts) if isinstance(transport, BusTickInC) else None
        if bus is not None:
            return BusTickPath(self, self._ts, bus)
        return PythonTickPath(self, self._ts)

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

    def reset(self) -> State:
        """FAULT or ESTOP -> INIT; the next tick shakes hands again."""
        self.fire(Event.RESET)
        self._close_link()
        return self.state

    def _close_link(self) -> None:
        if not self.link_open:
            return
        self.link_open = False
        try:
            self.transport.close()
        except Exception as exc:
            log.warning("closing the transport: %s: %s", type(exc).__name__, exc)

    # -- references --------------------------------------------------------------------
    def set_trajectory(self, traj: Trajectory | None, loop: bool = False,
                       driven: np.ndarray | None = None) -> None:
        """Follow `traj` from its start when RUNNING (and from its start again at every
        `start`; `resume` after `hold` continues where it paused). A finger it drives
        follows it at every tick; the others keep their API targets. `driven`: what
        Trajectory.checked_driven returned already (off the loop)."""
        if traj is not None and driven is None:
            driven = traj.checked_driven()
        self._ts.bind_trajectory(traj, loop, driven)

    # -- the tick ------------------------------------------------------------------------
    def tick(self, woke_ns: int, check_model: bool = True) -> None:
        state = self.machine.state
        if state is State.INIT:
            self.path.before_handshake()
            self.handshake()
            self._vent_and_record(self.machine.state)
            return
        self.path.tick(state, woke_ns)
        self.record_row(self.machine.state)
        if check_model:  # run_one checks after it timed the tick
            self.check_model(state)

    def found(self, events: int, transport_fault: Fault | None = None,
              firmware_fault: Fault | None = None, sequence: int | None = None) -> None:
        """What the C tick found: the end of a trajectory (HOLD), then the first fault in
        this order (overrun, the link, the sample, the frame, the firmware, the outputs),
        then a leak found after the send. Every check runs on every tick, so that each
        streak (misses, held readings, silence) counts every tick, fault or not."""
        if events & FOUND_TRAJECTORY_END:
            if self.trajectory is not None:
                log.info("trajectory %s finished after %.2f s", self.trajectory.source,
                         self.trajectory.duration_s)
            self.fire(Event.HOLD)
        fault = self.gate.first_fault(self._ts, events, self.hand, transport_fault, firmware_fault,
                                      sequence)
        if fault is not None:
            self.fault(fault)
        if events & FOUND_LEAK:
            self.fault(self.gate.follow_fault(self._ts.follow_result))

    def check_model(self, ticked: State) -> None:
        """The model check (plausibility.py) on a new sample; a fault vents at once over a bus."""
        link = self.path.link  # `ticked`: the state the tick began in (INIT: no sample read)
        if ticked is not State.INIT and self.link_open and (found := self.model_check.sample(
                link and round(link.simulator.time_s * self.rate_hz), self.machine.state in ACTIVE,
                self.hand, self.sent_kpa)):
            self.fault(self.gate.model_fault(found))
            if link is None:
                with contextlib.suppress(Exception):  # a link that failed: its own fault says so
                    self.transport.vent()

    def _vent_and_record(self, state: int) -> None:
        """A tick without control (INIT, shutdown): vent, record zeros, and `state` (a
        State, or SHUTDOWN_STATE for the shutdown's last row)."""
        self.hand.inputs.mode[:] = MODE_VENT
        if self.link_open:
            try:
                self.transport.vent()
            except Exception as exc:
                log.warning("venting: %s: %s", type(exc).__name__, exc)
        self.sent_kpa[:] = 0.0
        self.record_row(state)

    def record_row(self, state: int) -> None:
        self.recorder.push_tick(self.t_s, state)  # one C call: the row from the step's structs

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

    def add_slack(self, job: Callable[[int], None], first: bool = False) -> None:
        self.slack.insert(0 if first else len(self.slack), job)

    def on_state_change(self, callback: Callable[[State], None]) -> None:
        self.on_state.append(callback)

    @property
    def next_tick_index(self) -> int:
        return self.schedule.index if self.schedule is not None else self.tick_index + 1

    def time_hand_advance(self) -> list[int] | None:
        return self.path.timed_advance() if isinstance(self.path, CoreTickPath) else None

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

    @contextlib.contextmanager
    def stepping(self, reason: str) -> Iterator[None]:
        self.gc.start()
        try:
            yield
        finally:
            self.gc.stop()
            self.request_stop(reason)
            self.shutdown()

    def run_one(self, schedule: clock.Schedule) -> None:
        """Sleep to the next deadline, tick, then the slack jobs."""
        deadline = schedule.deadline_ns
        self.schedule = schedule
        self.tick_index = schedule.index
        self.t_s = schedule.index / self.rate_hz
        state = self.machine.state
        times = self._handshake_at(deadline) if state is State.INIT else self.path.tick_at(deadline, state)
        if times is None:  # a signal asked the loop to stop
            return
        woke, end = times
        self.missed_last = self.stats.add(deadline, woke, end)
        self.check_model(state)  # after the command went out, outside the tick's time
        skipped = schedule.advance(clock.now_ns())  # a deadline already gone is skipped
        if skipped:
            self.stats.skipped += skipped
            if self.state is State.RUNNING and not self.trajectory_done:
                self.trajectory_tick += skipped
        self.path.advance()
        slack_ns = schedule.deadline_ns - clock.now_ns()
        for job in self.slack:
            job(slack_ns)
        failure = self.recorder.after_tick(self.t_s, self.state, self.profile.recording.faults)
        if failure is not None:  # with recording.on_failure: fault (Recorder.after_tick)
            self.fault(Fault(Cause.RECORDING_FAILED, failure.describe()))
        self.gc.maybe_collect(self.stats.ticks, schedule.deadline_ns - clock.now_ns())

    def _handshake_at(self, deadline_ns: int) -> tuple[int, int] | None:
        """INIT: sleep to the deadline, then the handshake in Python."""
        if (woke := sleep_to(self, deadline_ns)) is None:
            return None
        self.tick(woke, check_model=False)
        end = clock.now_ns()
        time.sleep(0)  # the transport's writer thread sends the vent before the next tick
        return woke, end

    def shutdown(self) -> None:
        """Vent, record the vented tick, flush and close the recording, close the link.
        Runs however the loop ended (run()'s finally); each step runs even if one before
        it fails."""
        log.info("stopping (%s): venting", self.stop_reason)
        if self.schedule is not None:
            self.t_s = self.schedule.index / self.rate_hz  # the slot after the last tick
        self.hand.inputs.mode[:] = MODE_VENT
        for step in (self.hand.step, lambda: self._vent_and_record(SHUTDOWN_STATE),
                     self.recorder.close, self._close_link):
            try:
                step()
            except Exception as exc:
                log.error("shutting down: %s: %s", type(exc).__name__, exc)


__all__ = ["Supervisor"]
