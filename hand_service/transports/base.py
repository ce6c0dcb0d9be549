"""The transport contract: how the supervisor talks to a valve board.

A transport turns bus frames into SensorSample values and ValveCommand values into
frames. Wire details (DBC, framing, CRC) stay inside the transport and its profile.
Nothing here may block the tick: `latest()` and `send()` return at once.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class SensorSample:
    """One reading of every finger, as the firmware sent it."""

    sequence: int  # the firmware's sample count: +1 per sample it took, lost ones included
    received_s: float  # host monotonic clock when the sample was complete
    sensor_mv: np.ndarray
    pressure_meas_kpa: np.ndarray  # NaN where the board does not report it
    command_sequence: int = -1  # newest of our valve commands the board held at sampling (-1: none)
    # the longest run of the firmware's samples that never reached the host, since the sample
    # latest() returned before: samples that arrived and were replaced by a newer one before
    # the tick took it were not lost
    lost_in_a_row: int = 0


@dataclass
class FirmwareStatus:
    """What the firmware says of itself: its handshake and its newest status."""

    protocol_version: int
    firmware_version: str
    state: str = ""  # the firmware's state: booting, idle, running, watchdog_vented, fault
    vented: bool = False  # its valves are vented now: it is not applying the host's setpoints
    # times it vented on its own since the transport was made (its watchdog, a fault of its
    # own, a reboot). A count, not a level: a vent and the resumption after it may both
    # arrive between two ticks, and a status older than the host's first command says
    # "idle". The supervisor faults when it grows while it commands.
    vents: int = 0
    fault_code: int = 0  # a fault of the board's own (wire.messages.FirmwareFault), 0: none
    fault_text: str = ""  # its name
    injected_fault: int = 0  # the debug port's injected fault (FaultKind), 0: none; not the board's


@dataclass
class TransportHealth:
    """Counters for the API and the log. They only ever grow."""

    frames_in: int = 0
    frames_out: int = 0
    crc_errors: int = 0
    decode_errors: int = 0
    sequence_gaps: int = 0
    timeouts: int = 0
    reconnects: int = 0
    extra: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, int]:
        return {"frames_in": self.frames_in, "frames_out": self.frames_out,
                "crc_errors": self.crc_errors, "decode_errors": self.decode_errors,
                "sequence_gaps": self.sequence_gaps, "timeouts": self.timeouts,
                "reconnects": self.reconnects, **self.extra}


@dataclass(frozen=True)
class LinkProblem:
    """What a transport's own checks found wrong with the link (transports/checks.py): the
    supervisor faults on it. `kind` is the name of the supervisor's fault cause."""

    kind: str  # sample_late, sample_loss, sequence_stuck, clock_drift, bus_error, protocol_changed
    detail: str


class HandshakeError(Exception):
    """The firmware did not answer, or reported a protocol version the profile refuses."""


class Link(ABC):
    """One connection to a board. Only a bus transport's I/O threads call it (link.py)."""

    description = ""

    @abstractmethod
    def connect(self) -> None:
        """Open the port or bus; raise OSError (or the bus library's error) if it cannot."""

    @abstractmethod
    def close(self) -> None: ...

    @abstractmethod
    def read(self, timeout_s: float) -> list[Any]:
        """Whatever arrived (frames or byte chunks), waiting at most timeout_s for the first."""

    @abstractmethod
    def write(self, units: list[Any]) -> None: ...


class Transport(ABC):
    """open() (with the handshake), latest(), send(), close(): nothing blocks the tick."""

    kind: str = ""
    n_fingers: int = 0

    @abstractmethod
    def open(self) -> FirmwareStatus:
        """Connect and shake hands; HandshakeError if the firmware is wrong or silent."""

    @abstractmethod
    def close(self) -> None:
        """Release the bus or port. Safe to call twice."""

    @abstractmethod
    def latest(self) -> SensorSample | None:
        """The newest complete sample not returned before, or None. Never blocks."""

    @abstractmethod
    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        """Queue chamber-pressure setpoints (kPa) for every finger. Never blocks."""

    @abstractmethod
    def status(self) -> FirmwareStatus | None:
        """The last status/heartbeat the firmware reported."""

    @abstractmethod
    def health(self) -> TransportHealth:
        """Frame counters and error counts."""

    def link_problem(self) -> LinkProblem | None:
        """The first problem the transport's own checks found on the link since open() (a
        late sample on the board's clock, lost samples, a stuck sequence, a drifting clock,
        CAN errors, a protocol change), or None. Reading it costs the tick nothing: the
        checks run in the transport's I/O threads. A link without such checks has none."""
        return None

    def link_estimates(self) -> dict[str, float | None]:
        """What the transport's own checks estimate of the link now, for `status`: the
        command -> sensor round trip (round_trip_ms), the board's clock against the host's
        (clock_drift_ppm). None where not known yet; a link without such checks has none."""
        return {}

    def on_tick(self, tick_index: int) -> None:
        """The supervisor's schedule index for the tick about to read. A board on a bus
        keeps its own clock and has no use for it; the in-process simulated hand uses it
        to keep time with the host when the host skipped deadlines."""
        del tick_index

    def resume_at(self, tick_index: int) -> None:
        """The host's schedule went on to tick_index on purpose (a benchmark's bare-loop
        blocks), time the hand does not live through. A board on a bus lives through it on
        its own clock whatever the host says; the simulated hand stands still."""
        del tick_index

    def vent(self) -> None:
        """Command every valve to 0 kPa now."""
        self.send(np.zeros(self.n_fingers))

    def __enter__(self) -> Transport:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
