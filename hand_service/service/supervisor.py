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
from collections.abc import Callable

import numpy as np

import rtcore
from hand_service.config.profile import Profile
from hand_service.service import bus_tick
from hand_service.service.recorder import SHUTDOWN_STATE, Recorder
from hand_service.service.safety import Cause, Fault, FaultLog, SafetyGate
from hand_service.service.states import ACTIVE, LATCHED, REFS, Event, State, StateMachine
from hand_service.service.timing import GcControl, TickStats
from hand_service.service.trajectory import NOT_DRIVEN, Trajectory
from hand_service.transports import FirmwareStatus, HandshakeError, Transport
from rtcore import MODE_VENT, clock
from rtcore.tick import FOUND_LEAK, FOUND_TRAJECTORY_END, Tick

log = logging.getLogger(__name__)


class Supervisor:
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
        self._control, self._follow = self._ts.control, self._ts.follow
        # the transport says how the tick reaches the hand: on the in-process simulated
        # hand, the whole tick, sensors to valves, is one C call, and on the schedule the
        # sleep, that tick and its ring row are one C call too; else the transport in
        # Python around the C control and follow halves
        self.tick_path = transport.tick_path()
        in_core = None if self.tick_path.link is None else self._ts.on_link(self.tick_path.link)
        self._tick_core = None if in_core is None else in_core.tick
        self._tick_at = None if in_core is None else in_core.tick_at
        self._times_ns = Tick.times()  # its wake-up and end
        # the simulated hand lives through the period of the command just sent in the slack
        # after the tick, as a board's firmware runs beside the host
        self.advance_hand: Callable[[], object] | None = None if in_core is None else in_core.advance
        self._bus_tick = None if in_core is not None else transport.bus_tick(self._ts)  # can-v1: in C
        # the recording's rows; on the simulated hand with its true angle (the sample's)
        truth = None if self.tick_path.link is None else self.tick_path.link.simulator.c_outputs.angle_deg
        self.recorder.bind(self.hand.c_inputs, self.hand.c_outputs, self.sent_kpa, self._ts.c, truth)
        self._last_missed = False
        self._latched_causes: set[Cause] = set()
        self.on_fault: list[Callable[[Fault], None]] = []
        self.on_state: list[Callable[[State], None]] = []

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
        self._ts.bind_trajectory(traj, loop, driven)

    # -- the tick ------------------------------------------------------------------------
    def tick(self, woke_ns: int, check_model: bool = True) -> None:
        state = self.machine.state
        if state is State.INIT:
            if self._bus_tick is not None:
                self._bus_tick.pause()
            self.handshake()
            self._vent_and_record(self.machine.state)
            return
        if self._tick_core is not None:  # sensors, gate, references, step, valves: one C call
            events = self._tick_core(self.tick_index, REFS[state], self._last_missed, woke_ns)
            if events:
                self._found(events)
        elif self._bus_tick is not None:  # decode, control, encode: one C call (service/bus_tick.py)
            bus_tick.tick(self, state, woke_ns)
        else:
            bus_tick.python_tick(self, state, woke_ns)
        self._record(self.machine.state)
        if check_model:  # run_one checks after it timed the tick
            self.check_model(state)

    def _found(self, events: int, transport_fault: Fault | None = None,
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
        link = self.tick_path.link  # `ticked`: the state the tick began in (INIT: no sample read)
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
        self._record(state)

    def _record(self, state: int) -> None:
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
        self.tick_index = schedule.index
        self.t_s = schedule.index / self.rate_hz
        state = self.machine.state
        if self._tick_at is not None and state is not State.INIT:
            # the simulated hand: from the wake-up to the end of the tick, C only
            times = self._times_ns
            while (events := self._tick_at(deadline, self.spin_ns, self.tick_index, REFS[state],
                                           self._last_missed, self.t_s, state, times)) < 0:
                clock.check_sleep(times[0])  # a signal woke the sleep: nothing was done
                if self.stop_reason is not None:
                    return
            woke, end = times[0], times[1]
            if events:  # the state may change: the row is recorded here, after
                self._found(events)
                self._record(self.machine.state)
                end = clock.now_ns()
            else:  # the tick ended in C: how long until Python ran again, apart
                self.stats.add_return(clock.now_ns() - end)
        elif self._bus_tick is not None and state is not State.INIT:  # over can-v1: C only, too
            if (times := bus_tick.tick_at(self, deadline, state)) is None:
                return
            woke, end = times
        else:
            woke = clock.sleep_until_ns(deadline, self.spin_ns)
            while woke < 0:  # a signal: its handler has run; sleep on unless told to stop
                if self.stop_reason is not None:
                    return
                woke = clock.sleep_until_ns(deadline, self.spin_ns)
            self.tick(woke, check_model=False)
            end = clock.now_ns()
            time.sleep(0)  # the transport's writer thread sends the command before the model check
        self._last_missed = self.stats.add(deadline, woke, end)
        self.check_model(state)  # after the command went out, outside the tick's time
        skipped = schedule.advance(clock.now_ns())  # a deadline already gone is skipped
        if skipped:
            self.stats.skipped += skipped
            if self.state is State.RUNNING and not self.trajectory_done:
                self.trajectory_tick += skipped
        if self.advance_hand is not None:
            self.advance_hand()
        slack_ns = schedule.deadline_ns - clock.now_ns()
        for job in self.slack:
            job(slack_ns)
        failure = self.recorder.after_tick(self.t_s, self.state, self.profile.recording.faults)
        if failure is not None:  # with recording.on_failure: fault (Recorder.after_tick)
            self.fault(Fault(Cause.RECORDING_FAILED, failure.describe()))
        self.gc.maybe_collect(self.stats.ticks, schedule.deadline_ns - clock.now_ns())

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
