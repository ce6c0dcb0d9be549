"""The `sim` transport: the simulated hand in this process, in lockstep with the tick.

Each send() holds the commands for one sample period of the simulator and makes the
sample at its end available to the next latest(). When the host skips deadlines,
on_tick() lets the simulated time pass with the valves holding the last command. There
is no bus, so no frame is ever lost; the counters still count, so the supervisor sees
the same health as on hardware.
"""

from __future__ import annotations

import time

import numpy as np

from hand_service.profile import Profile
from hand_service.simulator import Contact, hand_simulator
from hand_service.transports.base import FirmwareStatus, SensorSample, Transport, TransportHealth


class SimTransport(Transport):
    kind = "sim"

    def __init__(self, profile: Profile, seed: int | None = None,
                 contacts: dict[str, Contact] | None = None) -> None:
        self.profile = profile
        self.n_fingers = len(profile.fingers)
        self.simulator = hand_simulator(profile, seed=seed, contacts=contacts)
        self._health = TransportHealth()
        self._status = FirmwareStatus(protocol_version=profile.protocol_version,
                                      firmware_version="sim")
        self._sequence = 0
        self._fresh = False
        self._open = False
        self._tick_index: int | None = None

    def open(self) -> FirmwareStatus:
        self._open = True
        self._fresh = True  # the reading before the first command
        return self._status

    def close(self) -> None:
        self._open = False

    def latest(self) -> SensorSample | None:
        if not (self._open and self._fresh):
            return None
        self._fresh = False
        self._health.frames_in += 1
        out = self.simulator.outputs
        sample = SensorSample(self._sequence, time.monotonic(), out.sensor_mv.copy(),
                              out.pressure_meas_kpa.copy())
        self._sequence += 1
        return sample

    def on_tick(self, tick_index: int) -> None:
        """Deadlines the host skipped still pass for the hand: the valves hold the last
        command through them, as a firmware on its own clock would, so the recording's
        time and the physics stay in step."""
        last, self._tick_index = self._tick_index, tick_index
        if not self._open or last is None or tick_index <= last + 1:
            return
        for _ in range(tick_index - last - 1):
            self.simulator.step()
        self._fresh = True

    def resume_at(self, tick_index: int) -> None:
        """The host's schedule went on to tick_index while the hand's time stood still: a
        benchmark's blocks of the bare loop are not the hand's time, and simulating them in
        the next tick (a second of hand in one tick) would time the simulator, not the tick."""
        self._tick_index = tick_index - 1

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        if not self._open:
            return
        self.simulator.command_kpa[:] = pressure_cmd_kpa
        self.simulator.step()
        self._health.frames_out += 1
        self._fresh = True

    def status(self) -> FirmwareStatus | None:
        return self._status

    def health(self) -> TransportHealth:
        return self._health
