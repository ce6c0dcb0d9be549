"""The simulated hand as a link (rtcore_sim_link, csrc/rtcore_sim_link.c): what a board's
wire would carry, one call at a time, on a simulator in the same process.

The link samples once per command it holds for a sample period, lives through the
deadlines the host skipped holding the last command, and simulates a sent command's
period later (`advance`): in the host's slack after the tick, as a board's firmware runs
beside the host, or at the latest when the next sample or command needs it.
"""

from __future__ import annotations

import functools

import numpy as np

from rtcore._rtcore import ffi, lib
from rtcore.config import MAX_FINGERS
from rtcore.sim import Simulator


class SimLink:
    """An rtcore_sim_link on a Simulator. `c_link` is the struct the tick runs on."""

    def __init__(self, simulator: Simulator) -> None:
        self.simulator = simulator
        self.c_link = link = ffi.new("rtcore_sim_link *")
        link.sim, link.out = simulator.c_sim, simulator.c_outputs
        link.command_kpa = simulator.c_command
        self.sensor_mv = np.zeros(MAX_FINGERS)
        self.pressure_meas_kpa = np.zeros(MAX_FINGERS)
        self._latest = functools.partial(lib.rtcore_sim_link_latest, link,
                                         ffi.cast("double *", ffi.from_buffer(self.sensor_mv)),
                                         ffi.cast("double *", ffi.from_buffer(self.pressure_meas_kpa)))
        self._send_buffer = np.zeros(MAX_FINGERS)
        self._send_ptr = ffi.cast("double *", ffi.from_buffer(self._send_buffer))
        self.advance = functools.partial(lib.rtcore_sim_link_advance, link)

    def open(self) -> None:
        self.c_link.open = 1
        self.c_link.fresh = 1  # the reading before the first command

    def close(self) -> None:
        self.c_link.open = 0

    def latest(self) -> bool:
        """A new sample into sensor_mv and pressure_meas_kpa: True, else False."""
        return bool(self._latest())

    def on_tick(self, tick_index: int) -> None:
        """The host's tick tick_index: skipped deadlines pass for the hand, holding the
        last command."""
        lib.rtcore_sim_link_on_tick(self.c_link, tick_index)

    def resume_at(self, tick_index: int) -> None:
        """The host's schedule jumps to tick_index while the hand's time stands still."""
        self.c_link.last_tick_index = tick_index - 1
        self.c_link.has_tick = 1

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        """Hold this command, and simulate its period now."""
        self._send_buffer[:len(pressure_cmd_kpa)] = pressure_cmd_kpa
        lib.rtcore_sim_link_send(self.c_link, self._send_ptr)
        self.advance()

    @property
    def sequence(self) -> int:
        """Samples taken."""
        return int(self.c_link.sequence)

    @property
    def frames_in(self) -> int:
        return int(self.c_link.frames_in)

    @property
    def frames_out(self) -> int:
        return int(self.c_link.frames_out)


__all__ = ["SimLink"]
