"""The supervisor's tick over can-v1 as one C call around python-can (rtcore_can_tick).

python-can does the bus I/O in the transport's threads, as for every bus: the reader thread
receives frames in batches and copies each SensorFinger frame's id and bytes into the tick's
batch (`add`); the tick hands the batch to C in one call, which decodes and reassembles the
samples, takes the newest one (the step's inputs), runs the tick's control half, encodes
the command frames and runs the follow check; the writer thread sends those frames, woken
right after the tick (`after`).

The reader thread still decodes every frame itself too (the C codec, can_c_codec.py), for
the handshake, the firmware's status and the SampleMonitor's counters and link checks: they
see each sample when it arrives, whether or not the tick runs (a bench's bare-loop blocks,
a stalled host), as on the Python path.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

import can

from hand_service.wire.can_c_codec import new_core
from hand_service.wire.can_codec import CanCodec
from rtcore.can import CanTickCore, tx_frames


@dataclass
class CommandFrames:
    """The command frames one tick encoded (a copy of its io's tx part), for the writer thread."""

    sequence: int  # the command's, unwrapped
    tx: bytes

    def frames(self) -> list[can.Message]:
        return [can.Message(arbitration_id=i, is_extended_id=False, data=data)
                for i, data in tx_frames(self.tx)]


class CanTickState:
    """What the transport keeps of the tick over can-v1: its codec struct, and once a
    supervisor binds it (bind), the batch the reader thread adds the samples' frames to."""

    def __init__(self, codec: CanCodec) -> None:
        self.core = new_core(codec)
        self.n_fingers = codec.n_fingers
        self.batch: CanTickCore | None = None
        # the newest command frames for the writer thread: a one-slot handoff, no lock
        self.slot: deque[CommandFrames] = deque(maxlen=1)
        # whether the tick in C takes the batch: not during the handshake (INIT), when the
        # reader thread empties it instead, so that the first tick after a reset never reads
        # frames that waited (a full batch drops the newest: a stale sample, a fault at tick 1)
        self.taking = False

    def bind(self, c_tick: Any) -> CanTickCore:
        self.batch = CanTickCore(self.core, c_tick)
        return self.batch

    def reset(self) -> None:
        """A new connection: nothing half-assembled, no last sample, nothing to send."""
        self.core.reset()
        if self.batch is not None:
            self.batch.clear()  # the reader thread, which alone adds, is the caller
        self.slot.clear()

    def forget_last_sample(self) -> None:
        """The stream starts over (a reboot): any sequence is new."""
        self.core.forget_last_sample()

    def add(self, frame: can.Message, received_s: float) -> None:
        """A received SensorFinger frame into the next tick's batch (the reader thread); while
        the tick does not take it, the batch is emptied instead."""
        if self.batch is None:
            return
        if self.taking:
            self.batch.add(frame.arbitration_id, bytes(frame.data), received_s)
        else:
            self.batch.clear()

    @property
    def dropped(self) -> int:
        """Frames that found the batch full."""
        return 0 if self.batch is None else self.batch.dropped

    @property
    def busy_ticks(self) -> int:
        """Ticks that left the batch to the next one (the reader thread was adding to it)."""
        return 0 if self.batch is None else self.batch.busy_ticks


class CanTick:
    """The tick over can-v1 for one supervisor tick struct (rtcore.tick.Tick.c)."""

    def __init__(self, state: CanTickState, c_tick: Any, transport: Any) -> None:
        self.transport = transport
        self._state = state
        self.core = state.bind(c_tick)
        self._slot = state.slot
        self.sequence: int | None = None  # the newest taken sample's, unwrapped (model check)
        self._wrapped = 0

    def _took(self, command: int) -> None:
        """After a tick: its frames to the slot, the newest sample's sequence unwrapped."""
        core = self.core
        self._slot.append(CommandFrames(command, core.tx()))
        if core.samples:
            wrapped = core.sample_sequence
            self.sequence = 0 if self.sequence is None else self.sequence + (wrapped - self._wrapped) % 256
            self._wrapped = wrapped

    def tick(self, refs: int, vent: bool, missed_last: bool, woke_ns: int) -> int:
        """Decode the batch, control, encode, follow: one C call. Returns the RTCORE_TICK_* bits."""
        self._state.taking = True
        command = self.transport.next_command_sequence()
        events = self.core.tick(refs, vent, missed_last, woke_ns, command)
        self._took(command)
        return events

    def tick_at(self, deadline_ns: int, spin_ns: int, refs: int, vent: bool, missed_last: bool,
                times_ns: Any) -> int:
        """Sleep to the deadline and tick, one C call (rtcore_can_tick_at): the RTCORE_TICK_*
        bits, or -1 when a signal woke the sleep (nothing done, no command counted)."""
        self._state.taking = True
        command = self.transport.command_sequence + 1
        events = self.core.tick_at(deadline_ns, spin_ns, refs, vent, missed_last, command, times_ns)
        if events < 0:
            return events
        self.transport.next_command_sequence()
        self._took(command)
        return events

    @property
    def taking(self) -> bool:
        return self._state.taking

    def pause(self) -> None:
        """The handshake runs in Python: the reader thread empties the batch until the next tick."""
        self._state.taking = False

    def after(self) -> None:
        """Right after the tick: wake the writer to send the frames it encoded."""
        self.transport.wake_writer()
