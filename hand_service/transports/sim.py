"""The `sim` transport: the simulated hand in this process, in lockstep with the tick.

Each send() holds the commands for one sample period of the simulator and makes the
sample at its end available to the next latest(). When the host skips deadlines,
on_tick() lets the simulated time pass with the valves holding the last command. There
is no bus, so no frame is ever lost; the counters still count, so the supervisor sees
the same health as on hardware.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from hand_service.profile import Profile
from hand_service.simulator import Contact, hand_simulator
from hand_service.transports.base import FirmwareStatus, SensorSample, Transport, TransportHealth
from rtcore._rtcore import ffi, lib


class SimTransport(Transport):
    """The link's state is an rtcore_sim_link in C, so that the supervisor's tick can run
    the whole exchange in one C call (rtcore_tick_sim) when nothing here is overridden
    (core_link()); these methods are the same exchange, one call at a time."""

    kind = "sim"
    _WIRE = ("open", "close", "latest", "send", "vent", "status", "on_tick", "resume_at")

    def __init__(self, profile: Profile, seed: int | None = None,
                 contacts: dict[str, Contact] | None = None) -> None:
        self.profile = profile
        self.n_fingers = len(profile.fingers)
        self.simulator = hand_simulator(profile, seed=seed, contacts=contacts)
        self._status = FirmwareStatus(protocol_version=profile.protocol_version,
                                      firmware_version="sim")
        self._link = ffi.new("rtcore_sim_link *")
        self._link.sim, self._link.out = self.simulator.c_sim, self.simulator.c_outputs
        self._link.command_kpa = self.simulator.c_command
        self._sensor_mv = np.zeros(lib.RTCORE_MAX_FINGERS)
        self._pressure_kpa = np.zeros(lib.RTCORE_MAX_FINGERS)
        self._latest = functools.partial(lib.rtcore_sim_link_latest, self._link,
                                         ffi.cast("double *", ffi.from_buffer(self._sensor_mv)),
                                         ffi.cast("double *", ffi.from_buffer(self._pressure_kpa)))
        self._send_buffer = np.zeros(lib.RTCORE_MAX_FINGERS)
        self._send_ptr = ffi.cast("double *", ffi.from_buffer(self._send_buffer))

    def core_link(self) -> object | None:
        """The rtcore_sim_link, for a tick in one C call, unless a subclass or a patch on
        this object changes what goes over the wire (a fake with faults overrides latest,
        send...): the C tick would skip it."""
        cls = type(self)
        if any(getattr(cls, name) is not getattr(SimTransport, name) or name in vars(self)
               for name in self._WIRE):
            return None
        return self._link

    def open(self) -> FirmwareStatus:
        self._link.open = 1
        self._link.fresh = 1  # the reading before the first command
        return self._status

    def close(self) -> None:
        self._link.open = 0

    def latest(self) -> SensorSample | None:
        if not self._latest():
            return None
        n = self.n_fingers
        return SensorSample(int(self._link.sequence) - 1, time.monotonic(), self._sensor_mv[:n].copy(),
                            self._pressure_kpa[:n].copy())

    def on_tick(self, tick_index: int) -> None:
        """Deadlines the host skipped still pass for the hand: the valves hold the last
        command through them, as a firmware on its own clock would, so the recording's
        time and the physics stay in step."""
        lib.rtcore_sim_link_on_tick(self._link, tick_index)

    def resume_at(self, tick_index: int) -> None:
        """The host's schedule went on to tick_index while the hand's time stood still: a
        benchmark's blocks of the bare loop are not the hand's time, and simulating them in
        the next tick (a second of hand in one tick) would time the simulator, not the tick."""
        self._link.last_tick_index = tick_index - 1
        self._link.has_tick = 1

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        self._send_buffer[:self.n_fingers] = pressure_cmd_kpa
        lib.rtcore_sim_link_send(self._link, self._send_ptr)
        lib.rtcore_sim_link_advance(self._link)  # its period now (the C tick leaves it to the slack)

    def status(self) -> FirmwareStatus | None:
        return self._status

    def health(self) -> TransportHealth:
        """No bus, so no frame is ever lost; the counters still count."""
        return TransportHealth(frames_in=int(self._link.frames_in), frames_out=int(self._link.frames_out))
