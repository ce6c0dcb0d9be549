"""The mock valve-board firmware: owns the simulated hand and speaks the profile's protocol.

On its own clock it steps the simulated hand one sample period with the setpoints it
holds and sends the sensor readings (100 Hz at the default rate), with a 10 Hz status
heartbeat. It applies each complete valve command it receives, answers the version
handshake, and runs its own watchdog: when no valid command has come for
safety.firmware_watchdog_ms it vents every valve (0 kPa) and says so in its status.
Faults are injected on request from its debug port (faults.py); one of them is a fault of
the board's own (FIRMWARE_FAULT): it vents, ignores commands and reports the fault code
in its status, as a board with a failed valve driver would. It keeps time on its own
clock (clock.py), which a CLOCK_DRIFT fault makes run fast or slow.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import can
import numpy as np

from hand_service.config.profile import Profile
from hand_service.firmware.clock import BoardClock
from hand_service.firmware.faults import FaultInjector
from hand_service.firmware.ports import CanBusPort, FirmwarePort
from hand_service.simulator import hand_simulator
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.can_errors import bus_error_frame, bus_off_frame
from hand_service.wire.messages import (
    FaultKind,
    FaultRequest,
    FirmwareFault,
    FirmwareState,
    Message,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
    VersionRequest,
    fault_name,
    firmware_fault,
    signed_value,
)
from hand_service.wire.serial_codec import SerialCodec

log = logging.getLogger("hand_service.firmware")

FIRMWARE_VERSION = (1, 0, 0)
STATUS_EVERY_SAMPLES = 10
DEFAULT_BOOT_MS = 200
CATCH_UP_SAMPLES = 25  # after a stall of this process, at most this many samples in a burst
DEFAULT_ERROR_FRAMES_PER_S = 100
DEFAULT_DRIFT_PPM = 20000


def codec_for(profile: Profile) -> CanCodec | SerialCodec:
    if profile.transport["kind"] == "can":
        return CanCodec(profile.transport["dbc"], len(profile.fingers))
    return SerialCodec(len(profile.fingers))


class MockFirmware:
    def __init__(self, profile: Profile, port: FirmwarePort, protocol_version: int | None = None,
                 firmware_version: tuple[int, int, int] = FIRMWARE_VERSION, seed: int | None = None) -> None:
        self.profile = profile
        self.port = port
        self.codec = codec_for(profile)
        self.protocol_version = profile.protocol_version if protocol_version is None else protocol_version
        self.firmware_version = firmware_version
        self.n = len(profile.fingers)
        self.sim = hand_simulator(profile, seed=seed)
        self.period_s = 1.0 / profile.control.rate_hz
        self.watchdog_s = profile.safety["firmware_watchdog_ms"] / 1e3
        transport = profile.transport
        self.adc_range_mv = (transport.get("sensor_min_mv", -np.inf), transport.get("sensor_max_mv", np.inf))
        self.faults = FaultInjector(self.n, profile.simulation["seed"] if seed is None else seed)
        self.stop_event = threading.Event()
        self.command_kpa = np.zeros(self.n)
        self.state = FirmwareState.BOOTING
        self.fault_code: FirmwareFault | int = FirmwareFault.NONE  # the board's own fault
        self.sequence = 0
        self.command_sequence = 0
        self.last_command_s = 0.0
        self.boot_s = 0.0
        self.boot_end_s = 0.0
        self.samples = 0
        self.vent_times_s: list[float] = []  # monotonic time of every watchdog vent
        self.clock = BoardClock()
        self._error_frame_credit = 0.0

    # -- the main loop ---------------------------------------------------------------------

    def run(self, seconds: float | None = None) -> None:
        clock = self.clock
        start = clock.now()
        self._announce(start)
        next_sample = start + self.period_s
        while not self.stop_event.is_set():
            now = clock.now()
            if seconds is not None and now - start >= seconds:
                break
            deadline = min(t for t in self._deadlines(next_sample) if t is not None)
            for unit in self.port.read(max(0.0, clock.host_seconds(deadline - now))):
                for message in self.codec.decode(unit):
                    self._handle(message, clock.now())
            now = clock.now()
            for kind in self.faults.expire(now):
                log.info("fault %s ended", kind.name.lower())
            drift = self.faults.value(FaultKind.CLOCK_DRIFT, DEFAULT_DRIFT_PPM)
            clock.set_drift_ppm(0 if drift is None else signed_value(drift))
            self._own_fault(now)
            if self.state == FirmwareState.RUNNING and now - self.last_command_s > self.watchdog_s:
                self._vent(now)
            if self.state == FirmwareState.BOOTING and now >= self.boot_end_s:
                self._announce(now)
            # a board's sample timer does not stall: the samples this process missed while it
            # was held up are taken now, in a burst
            taken = 0
            while now >= next_sample and taken < CATCH_UP_SAMPLES:
                self._sample(now)
                next_sample += self.period_s
                taken += 1
            if now >= next_sample:  # far behind (a stalled machine): skip ahead
                next_sample = now + self.period_s
            self.port.write(self.faults.release(now))

    def _deadlines(self, next_sample: float) -> list[float | None]:
        watchdog = self.last_command_s + self.watchdog_s if self.state == FirmwareState.RUNNING else None
        boot = self.boot_end_s if self.state == FirmwareState.BOOTING else None
        return [next_sample, watchdog, boot, self.faults.next_release_s()]

    def _send(self, message: Message, now: float) -> None:
        if self.state == FirmwareState.BOOTING:
            return
        self.port.write(self.faults.outgoing(self.codec.encode(message), now))

    def _status(self, now: float) -> None:
        rx_errors = self.codec.stats.crc_errors + self.codec.stats.decode_errors
        self._send(Status(self.state, int((now - self.boot_s) * 1e3), self.faults.current, rx_errors,
                          self.fault_code), now)

    # -- what the firmware does ------------------------------------------------------------

    def _handle(self, message: Message, now: float) -> None:
        if self.state == FirmwareState.BOOTING:
            return
        if FaultKind.BUS_OFF in self.faults.active and not isinstance(message, FaultRequest):
            return  # bus-off: nothing arrives (the debug port is not on the bus)
        if isinstance(message, ValveCommand):
            if self.state == FirmwareState.FAULT:
                return  # a board at fault keeps its valves vented whatever it is told
            if FaultKind.VALVES_IGNORED not in self.faults.active:  # else it acknowledges, holds
                self.command_kpa[:] = message.pressure_cmd_kpa
            self.command_sequence = message.sequence
            self.last_command_s = now
            if self.state != FirmwareState.RUNNING:
                log.info("valid commands arriving: applying setpoints (was %s)", self.state.name.lower())
                self.state = FirmwareState.RUNNING
                self._status(now)
        elif isinstance(message, VersionRequest):  # the handshake: state first, then version
            self._status(now)
            self._send(self._version(), now)
        elif isinstance(message, FaultRequest):
            log.warning("debug port: injecting fault %s (finger %d, %d ms, value %d)",
                        message.kind.name.lower(), message.finger_index, message.duration_ms, message.value)
            if message.kind == FaultKind.REBOOT:
                self._reboot(now, message.value or DEFAULT_BOOT_MS)
            elif not self._link_carries(message.kind):
                log.warning("fault %s: this link (%s) cannot carry it; ignored",
                            message.kind.name.lower(), self.port.description)
            else:
                self.faults.request(message, now)
                if message.kind == FaultKind.BUS_OFF:
                    self.port.write([bus_off_frame()])  # the driver says so, then nothing crosses
                if not self._own_fault(now):
                    self._status(now)
                if message.kind == FaultKind.PROTOCOL_CHANGE:
                    self._send(self._version(), now)

    def _link_carries(self, kind: FaultKind) -> bool:
        """CAN error frames reach the host where its driver reports them (python-can's
        SocketCAN-style error frames; SLCAN's Lawicel protocol has none); bus-off exists on
        CAN only (over SLCAN it is silence); a NaN flex reading crosses where the wire has a
        value for it (serial-v1's f32; can-v1's flex_mv has none)."""
        can_link = isinstance(self.codec, CanCodec)
        if kind == FaultKind.CAN_ERROR_FRAMES:
            return self.port.carries_error_frames
        if kind == FaultKind.BUS_OFF:
            return can_link
        if kind == FaultKind.SENSOR_NAN:
            return not can_link or self.codec.carries_nan("flex_mv")  # type: ignore[union-attr]
        return True

    def _version(self) -> VersionInfo:
        protocol = self.faults.value(FaultKind.PROTOCOL_CHANGE, self.protocol_version + 1)
        return VersionInfo(self.protocol_version if protocol is None else protocol,
                           self.firmware_version, self.n)

    def _sample(self, now: float) -> None:
        self.sim.command_kpa[:] = self.command_kpa
        self.sim.step()
        self.samples += 1
        out = self.sim.outputs
        sensor_mv = self.faults.sensors(np.clip(out.sensor_mv, *self.adc_range_mv))
        pressure_kpa = self.faults.pressures(out.pressure_meas_kpa.copy())
        self._send(SensorReport(self.sequence, self.command_sequence, sensor_mv.tolist(),
                                pressure_kpa.tolist()), now)
        if FaultKind.SEQUENCE_STUCK not in self.faults.active:
            self.sequence = (self.sequence + 1) % 256
        if self.samples % STATUS_EVERY_SAMPLES == 0:
            self._status(now)
        self._error_frames()

    def _error_frames(self) -> None:
        """CAN_ERROR_FRAMES: error frames at `value` per second, as the host's driver
        reports errors on a noisy bus (they do not pass through the board's own faults)."""
        per_s = self.faults.value(FaultKind.CAN_ERROR_FRAMES, DEFAULT_ERROR_FRAMES_PER_S)
        if per_s is None:
            self._error_frame_credit = 0.0
            return
        self._error_frame_credit += per_s * self.period_s
        count = int(self._error_frame_credit)
        self._error_frame_credit -= count
        self.port.write([bus_error_frame() for _ in range(count)])

    def _vent(self, now: float) -> None:
        self.command_kpa[:] = 0.0
        self.state = FirmwareState.WATCHDOG_VENTED
        host_s = time.monotonic()  # the machine's clock, shared with the host's processes
        self.vent_times_s.append(host_s)
        log.warning("watchdog: no valid command for %.0f ms: vented every valve (t_monotonic_s=%.6f)",
                    (now - self.last_command_s) * 1e3, host_s)
        self._status(now)

    def _own_fault(self, now: float) -> bool:
        """Enter or leave a fault of the board's own (FIRMWARE_FAULT on the debug port);
        True if the state changed (and the status went out)."""
        injected = self.faults.active.get(FaultKind.FIRMWARE_FAULT)
        if injected is not None and self.state not in (FirmwareState.FAULT, FirmwareState.BOOTING):
            self.fault_code = firmware_fault(injected.request.value or FirmwareFault.VALVE_DRIVER)
            self.command_kpa[:] = 0.0
            self.state = FirmwareState.FAULT
            log.warning("fault %d (%s): vented every valve, ignoring commands", self.fault_code,
                        fault_name(self.fault_code))
        elif injected is None and self.state == FirmwareState.FAULT:
            self.fault_code = FirmwareFault.NONE
            self.state = FirmwareState.IDLE
            log.info("fault cleared: valves vented until the next valid command")
        else:
            return False
        self._status(now)
        return True

    def _reboot(self, now: float, boot_ms: int) -> None:
        log.warning("rebooting: every valve vented, silent for %d ms", boot_ms)
        self.command_kpa[:] = 0.0
        self.fault_code = FirmwareFault.NONE
        self.faults.clear()
        self.state = FirmwareState.BOOTING
        self.boot_end_s = now + boot_ms / 1e3

    def _announce(self, now: float) -> None:
        """Boot complete: counters from zero, valves vented until the first valid command."""
        self.state = FirmwareState.IDLE
        self.boot_s = now
        self.sequence = self.command_sequence = 0
        self._send(self._version(), now)
        self._status(now)
        log.info("booted: firmware %s, protocol %d, %d fingers, watchdog %.0f ms",
                 ".".join(map(str, self.firmware_version)), self.protocol_version, self.n,
                 self.watchdog_s * 1e3)


class MockThread:
    """The mock firmware in a thread of this process, on python-can's virtual bus."""

    def __init__(self, firmware: MockFirmware) -> None:
        self.firmware = firmware
        self.thread = threading.Thread(target=firmware.run, name="mock-firmware", daemon=True)

    def start(self) -> MockThread:
        self.thread.start()
        return self

    def stop(self) -> None:
        self.firmware.stop_event.set()
        self.thread.join(timeout=5.0)
        self.firmware.port.close()

    def __enter__(self) -> MockThread:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()


def run_in_thread(profile: Profile, channel: str | None = None, **options: Any) -> MockThread:
    """Start the mock on the profile's virtual CAN channel (or `channel`) in a thread."""
    settings = profile.transport
    if settings["kind"] != "can" or settings["interface"] != "virtual":
        raise ValueError("run_in_thread needs a profile on python-can's virtual bus")
    bus = can.Bus(interface="virtual", channel=channel or settings["channel"])
    return MockThread(MockFirmware(profile, CanBusPort(bus), **options)).start()
