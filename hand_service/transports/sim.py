"""The `sim` transport: the simulated hand in this process, in lockstep with the tick.

Each send() holds the commands for one sample period of the simulator and makes the
sample at its end available to the next latest(). When the host skips deadlines,
on_tick() lets the simulated time pass with the valves holding the last command. There
is no bus, so no frame is ever lost; the counters still count, so the supervisor sees
the same health as on hardware.
"""

from __future__ import annotations

import time
from typing import ClassVar

import numpy as np

from hand_service.config.profile import Profile
from hand_service.simulator import Contact, hand_simulator
from hand_service.transports.base import FirmwareStatus, SensorSample, Transport, TransportHealth
from hand_service.transports.in_c import HandInProcess
from rtcore.sim_link import SimLink

# what crosses the wire: a class that changes any of these must say how its tick runs
WIRE = ("open", "close", "latest", "send", "vent", "status", "on_tick", "resume_at")


class SimTransport(Transport, HandInProcess):
    """The link's state is an rtcore_sim_link in C (rtcore.sim_link), so that the
    supervisor's tick can run the whole exchange in one C call: core_link() says so
    while `tick_in_core` is true. These methods are the same exchange, one call at a time,
    for a tick in Python.

    A subclass that changes what goes over the wire (a fake with faults overrides latest,
    send...) sets tick_in_core = False, or the C tick would skip its overrides; one that
    overrides a wire method without saying so is refused when it is defined."""

    kind = "sim"
    tick_in_core: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs: object) -> None:
        super().__init_subclass__(**kwargs)
        changed = [name for name in WIRE if name in vars(cls)]
        if changed and cls.tick_in_core:
            raise TypeError(f"{cls.__name__} overrides {', '.join(changed)} of the simulated hand's "
                            "link: set tick_in_core = False, so the tick goes through them")

    def __init__(self, profile: Profile, seed: int | None = None,
                 contacts: dict[str, Contact] | None = None) -> None:
        self.profile = profile
        self.n_fingers = len(profile.fingers)
        self.simulator = hand_simulator(profile, seed=seed, contacts=contacts)
        self._status = FirmwareStatus(protocol_version=profile.protocol_version,
                                      firmware_version="sim")
        self.link = SimLink(self.simulator)

    def core_link(self) -> SimLink | None:
        """The whole tick in C on the link, unless this class goes through Python."""
        return self.link if self.tick_in_core else None

    def open(self) -> FirmwareStatus:
        self.link.open()
        return self._status

    def close(self) -> None:
        self.link.close()

    def latest(self) -> SensorSample | None:
        link = self.link
        if not link.latest():
            return None
        n = self.n_fingers
        return SensorSample(link.sequence - 1, time.monotonic(), link.sensor_mv[:n].copy(),
                            link.pressure_meas_kpa[:n].copy())

    def on_tick(self, tick_index: int) -> None:
        """Deadlines the host skipped still pass for the hand: the valves hold the last
        command through them, as a firmware on its own clock would, so the recording's
        time and the physics stay in step."""
        self.link.on_tick(tick_index)

    def resume_at(self, tick_index: int) -> None:
        """The host's schedule went on to tick_index while the hand's time stood still: a
        benchmark's blocks of the bare loop are not the hand's time, and simulating them in
        the next tick (a second of hand in one tick) would time the simulator, not the tick."""
        self.link.resume_at(tick_index)

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        self.link.send(pressure_cmd_kpa)  # its period now (the C tick leaves it to the slack)

    def status(self) -> FirmwareStatus | None:
        return self._status

    def health(self) -> TransportHealth:
        """No bus, so no frame is ever lost; the counters still count."""
        return TransportHealth(frames_in=self.link.frames_in, frames_out=self.link.frames_out)
