"""A conversation with the board: send as a host does, record everything that comes back.

The session numbers valve commands as the host does (the first is 1, +1 per command,
sent modulo 256) and remembers when each left, so a sample's command_sequence gives the
command -> sample echo time. pump() receives for a while, optionally sending a command
at the profile's rate, and returns what arrived in that time.
"""

from __future__ import annotations

import dataclasses
import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from hand_service.boardcheck.cpu_wait import CpuWait
from hand_service.boardcheck.link import BoardLink, Received
from hand_service.boardcheck.sense import FingerSense
from hand_service.wire.messages import (
    SEQUENCE_MODULO,
    FirmwareState,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
)

STALL_MIN_S = 0.005  # a wait for the link this much longer than asked: this process stalled
CPU_WAIT_MIN_S = 0.001  # a wait for a CPU this long or longer is booked as this process's stall
GRACE_PERIODS = 2  # after a stall, its length and this many sample periods more (host_stall.py's grace)
GRACE_LOOKBACK = 64  # how many of the latest stalls may still grant one


@dataclass(frozen=True)
class Settings:
    """What the check expects of the board (the profile's) and how long it looks."""

    protocol_version: int
    n_fingers: int
    rate_hz: float
    watchdog_ms: float
    handshake_timeout_ms: float
    stale_ms: float  # the host's stale_sensor_ticks, as time
    loss_max_percent: float
    clock_drift_max_ppm: float
    window_s: float  # how long the stream check listens
    pressure_kpa: float  # the setpoint the valve checks command
    latency_ms: float  # what the link and this host may add to any time the board keeps
    pressure_measured: bool = True  # the profile's safety.pressure_measured
    host_stall_max_ms: float = 0.0  # the profile's: a stall the daemon rides through at most
    fingers: tuple[FingerSense, ...] = ()  # what each finger's sensors and model say (plant check)

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def answer_wait_ms(self) -> float:
        """How long a VersionRequest's answer is waited for: the host's handshake timeout and
        what the link may add to it (an emulator's UART, a loaded machine)."""
        return self.handshake_timeout_ms + self.latency_ms


@dataclass
class Session:
    link: BoardLink
    settings: Settings
    progress: Callable[[str], None] = lambda text: None
    tell: Callable[[str], None] = lambda text: None  # what the user must do: never silenced
    command_sequence: int = 0  # unwrapped, as the host counts; the first command is 1
    sent_s: dict[int, float] = field(default_factory=dict)  # wrapped sequence -> time sent
    log: list[Received] = field(default_factory=list)
    last_status: Status | None = None
    command_times_s: list[float] = field(default_factory=list)  # when each valid command left
    # this process's own stalls (from, to), each booked at the end of the stretch of the loop it
    # fell in: its waits for a CPU (cpu_wait.py), or a wait for the link that overran what it
    # asked for by more than STALL_MIN_S (a stall the CPU wait does not see: paging, disk),
    # whichever is longer. A message is late by those since this process last looked at the
    # link (Received.late_s): it came after that look, and waited through them at most. And as
    # the daemon rides a stall of the host through (transports/host_stall.py), a gap that ends
    # in a message read within a stall's length and GRACE_PERIODS sample periods after it is
    # excused that stall too (Received.grace_s), if it is one the daemon would ride through
    # (host_stall_max_ms): a board on the same busy machine stalls with this process, and
    # catches up after it
    stalls: list[tuple[float, float]] = field(default_factory=list)
    cpu: CpuWait = field(default_factory=CpuWait, repr=False)
    _cpu_waited_s: float | None = field(default=None, init=False, repr=False)
    _unlooked_stall_s: float = field(default=0.0, init=False, repr=False)  # booked since the last look
    _looked_s: float | None = field(default=None, init=False, repr=False)  # when the last look ended

    def command(self, pressure_kpa: float) -> ValveCommand:
        """Send a valve command of `pressure_kpa` on every finger."""
        self.command_sequence += 1
        command = ValveCommand(self.command_sequence % SEQUENCE_MODULO,
                               [pressure_kpa] * self.settings.n_fingers)
        self.link.send(command)
        self.sent_s[command.sequence] = time.monotonic()  # written: the board can have it from now
        self.command_times_s.append(self.sent_s[command.sequence])
        return command

    def next_command(self, pressure_kpa: float) -> ValveCommand:
        """The command command() would send next, not sent (to send it behind rubbish)."""
        self.command_sequence += 1
        command = ValveCommand(self.command_sequence % SEQUENCE_MODULO,
                               [pressure_kpa] * self.settings.n_fingers)
        self.sent_s[command.sequence] = time.monotonic()
        self.command_times_s.append(self.sent_s[command.sequence])
        return command

    def pump(self, seconds: float, pressure_kpa: float | None = None,
             until: Callable[[Received], bool] | None = None) -> list[Received]:
        """Receive for `seconds` (or until `until` is true of a message); with `pressure_kpa`,
        send that command every sample period meanwhile."""
        start = time.monotonic()
        self._book(self._cpu_wait_s(), start)  # since the last pump: the checks' own work between
        end = start + seconds
        next_command = start
        got: list[Received] = []
        while True:
            now = time.monotonic()
            if now >= end:
                return got
            if pressure_kpa is not None and now >= next_command:
                self.command(pressure_kpa)
                self._book(self._cpu_wait_s(), time.monotonic())
                next_command += self.settings.period_s
                if next_command < now:  # this process stalled: no burst of stale commands
                    next_command = now + self.settings.period_s
            wait = end - now if pressure_kpa is None else min(end, next_command) - now
            # in slices of a sample period at most, so that an overrun is measured to within one
            wait = min(max(wait, 0.0), self.settings.period_s)
            done = False
            received = self.link.receive(wait)
            woke = time.monotonic()
            overrun_s = woke - now - wait
            self._book(max(self._cpu_wait_s(), overrun_s if overrun_s > STALL_MIN_S else 0.0), woke)
            received = self._lateness(received, woke)
            for item in received:
                self.log.append(item)
                got.append(item)
                if isinstance(item.message, Status):
                    self.last_status = item.message
                done = done or (until is not None and until(item))
            if done:  # the rest of what arrived with it is kept too
                return got

    def _cpu_wait_s(self) -> float:
        """This thread's wait for a CPU since the last call, if CPU_WAIT_MIN_S or more; else 0."""
        waited_s = self.cpu.waited_s()
        if waited_s is None:
            return 0.0
        last_s, self._cpu_waited_s = self._cpu_waited_s, waited_s
        return waited_s - last_s if last_s is not None and waited_s - last_s >= CPU_WAIT_MIN_S else 0.0

    def _book(self, stall_s: float, at_s: float) -> None:
        """A stall of this process ending at at_s: what the board sent in it was read that much
        later than it could have been."""
        if stall_s > 0.0:
            self.stalls.append((at_s - stall_s, at_s))
            self._unlooked_stall_s += stall_s

    def _lateness(self, received: list[Received], looked_s: float) -> list[Received]:
        """What one look at the link (ending at looked_s) read, each late by this process's
        stalls since the look before (it came after that one), and never by more than the time
        since then."""
        stall_s, since_s = self._unlooked_stall_s, self._looked_s
        self._unlooked_stall_s, self._looked_s = 0.0, looked_s
        out = []
        for item in received:
            late_s = stall_s if since_s is None else min(stall_s, item.t_s - since_s)
            grace_s = self._grace_s(item.t_s, since_s)
            out.append(dataclasses.replace(item, late_s=late_s, grace_s=grace_s)
                       if late_s > 0.0 or grace_s > 0.0 else item)
        return out

    def _grace_s(self, t_s: float, since_s: float | None) -> float:
        """The longest stall of this process, no longer than host_stall_max_ms, that ended
        before its last look at the link but no longer before t_s than its own length and
        GRACE_PERIODS sample periods."""
        if since_s is None:
            return 0.0
        grace_s = GRACE_PERIODS * self.settings.period_s
        ride_max_s = self.settings.host_stall_max_ms / 1e3
        return max((b - a for a, b in self.stalls[-GRACE_LOOKBACK:]
                    if b <= since_s and b - a <= ride_max_s and t_s <= b + (b - a) + grace_s), default=0.0)

    def longest_pause_ms(self, since: int) -> float:
        """The longest time between two valid commands this host sent, from command `since`
        on (unwrapped count): a busy host can pause longer than the watchdog time, and
        then the board is right to vent."""
        times = self.command_times_s[max(0, since - 1):]
        return max((1e3 * (b - a) for a, b in itertools.pairwise(times)), default=0.0)

    def stalled_s(self, start_s: float, end_s: float) -> float:
        """How long this process itself stalled between start_s and end_s."""
        return sum(max(0.0, min(b, end_s) - max(a, start_s)) for a, b in self.stalls)

    def state(self) -> FirmwareState | None:
        return None if self.last_status is None else self.last_status.state


def samples(items: list[Received]) -> list[tuple[float, SensorReport]]:
    return [(r.t_s, r.message) for r in items if isinstance(r.message, SensorReport)]


def statuses(items: list[Received]) -> list[tuple[float, Status]]:
    return [(r.t_s, r.message) for r in items if isinstance(r.message, Status)]


def versions(items: list[Received]) -> list[tuple[float, VersionInfo]]:
    return [(r.t_s, r.message) for r in items if isinstance(r.message, VersionInfo)]
