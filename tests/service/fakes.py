"""Transports with faults injected, over the real simulated hand, for the supervisor's
fault tests: the supervisor only sees the Transport ABC, as it will on CAN or serial."""

from __future__ import annotations

import numpy as np

from hand_service.config.profile import Profile
from hand_service.transports import FirmwareStatus, HandshakeError, SensorSample
from hand_service.transports.sim import SimTransport


class FaultyTransport(SimTransport):
    """The sim transport, with switches: each fault can be turned on at any tick."""

    tick_in_core = False  # the faults are in latest() and send(): the tick goes through them

    def __init__(self, profile: Profile, **options: object) -> None:
        super().__init__(profile, **options)  # type: ignore[arg-type]
        self.silent = False  # samples are lost: latest() returns nothing, the sequence runs on
        self.late = False  # samples are late: latest() returns nothing, the next one is the next
        self.lost = False  # every call raises: the link is gone
        self.refuse = False  # send() refuses (ValueError) a command other than 0 kPa, as a wire would
        self.fail_handshake = 0  # this many open() calls fail
        self.sensor_override: np.ndarray | None = None  # replaces the sensor mV
        self.pressure_override: np.ndarray | None = None  # replaces the measured kPa
        self.sensor_offset_mv: np.ndarray | None = None  # added to the sensor mV (a drift, moved by the test)
        self.fault_code = 0
        self.firmware_vents = 0  # vents the firmware reports having done on its own
        self._lost = 0  # samples swallowed while silent, in a row
        self.sent: list[np.ndarray] = []
        self.vents = 0
        self.opens = 0

    def open(self) -> FirmwareStatus:
        self.opens += 1
        if self.fail_handshake:
            self.fail_handshake -= 1
            raise HandshakeError("firmware did not answer the handshake")
        return super().open()

    def latest(self) -> SensorSample | None:
        if self.lost:
            raise OSError("device unplugged")
        if self.late:
            return None
        sample = super().latest()
        if sample is None:
            return None
        if self.silent:
            self._lost += 1
            return None
        sample.lost_in_a_row, self._lost = self._lost, 0
        if self.sensor_override is not None:
            sample.sensor_mv = self.sensor_override.copy()
        if self.sensor_offset_mv is not None:
            sample.sensor_mv = sample.sensor_mv + self.sensor_offset_mv
        if self.pressure_override is not None:
            sample.pressure_meas_kpa = self.pressure_override.copy()
        return sample

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        if self.lost:
            raise OSError("device unplugged")
        if self.refuse and np.any(pressure_cmd_kpa != 0.0):
            raise ValueError("pressure command: the wire cannot carry it")
        self.sent.append(np.array(pressure_cmd_kpa, dtype=float))
        super().send(pressure_cmd_kpa)

    def vent(self) -> None:
        self.vents += 1
        super().vent()

    def status(self) -> FirmwareStatus | None:
        status = super().status()
        if status is not None and self.fault_code:
            return FirmwareStatus(status.protocol_version, status.firmware_version, vented=True,
                                  fault_code=self.fault_code, fault_text="valve driver over-temperature")
        if status is not None and self.firmware_vents:
            return FirmwareStatus(status.protocol_version, status.firmware_version,
                                  state="watchdog_vented", vented=True, vents=self.firmware_vents)
        return status
