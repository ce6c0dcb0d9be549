"""`run --foxglove [PORT]`: the hand live in Foxglove, over the Foxglove WebSocket protocol
(the `foxglove-sdk` package), on 127.0.0.1 only.

A process of its own beside the daemon, as the live view is (view/beside.py): it reads the
daemon's recording ring read-only (view/ring_tap.py), so the tick never waits for it, and
asks the daemon for its status four times a second. Every row the daemon records, at the
control rate, is published on the channels of the MCAP export, with their schemas and
metadata (export/mcap_log.py: `/hand` with `t` and `state`, `/hand/<finger>` with that
finger's quantities), each message's log time the wall clock at the row's `t`. The
channels are advertised when a recording starts (the ring exists only while the daemon
records); a recording of other fingers advertises them again.

    python -m hand_service.view.foxglove --socket SOCK [--port PORT] [--with-daemon PID]
    python -m hand_service.view.foxglove --ring PATH --fingers a,b --rate HZ ...   (bench --foxglove)
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.api.client import ApiError
from hand_service.export.mcap_log import ChannelSpec, channel_specs, table_cells
from hand_service.export.table import Table
from hand_service.export.units import unit_of
from hand_service.service.recorder_writer import HEAD, QUANTITIES, STATE_NAMES, csv_header
from hand_service.view.daemon_link import STATUS_EVERY_S, DaemonLink, LinkOptions
from hand_service.view.ring_tap import RingFollower
from rtcore.config import MODE_FORCE, MODE_NAMES, MODE_POSITION

log = logging.getLogger(__name__)

HOST = "127.0.0.1"  # loopback only
DEFAULT_PORT = 8765  # Foxglove's own default for a WebSocket connection
POLL_HZ = 50.0  # ring reads per second; every row is published, in batches


def ring_table(rows: np.ndarray, fingers: list[str]) -> Table:
    """Ring rows as the table the CSV of the same rows would read as (export/table.py): the
    state and each mode by name, flags as integers, a reference only under its mode."""
    n = len(fingers)
    columns: dict[str, Any] = {"t": rows[:, 0].astype(np.float64),
                               "state": [STATE_NAMES[int(c)] if 0 <= c < len(STATE_NAMES) else "?"
                                         for c in rows[:, 1]]}
    mode_at = len(HEAD) + QUANTITIES.index("mode") * n
    for f, finger in enumerate(fingers):
        mode = rows[:, mode_at + f]
        for q, name in enumerate(QUANTITIES):
            values = rows[:, len(HEAD) + q * n + f]
            column = f"{name}_{finger}"
            if name == "mode":
                columns[column] = [MODE_NAMES.get(int(v), "?") for v in values]
            elif name == "flags":
                columns[column] = values.astype(np.int64)
            else:
                values = values.astype(np.float64)
                if name == "angle_ref_deg":
                    values = np.where(mode == MODE_POSITION, values, np.nan)
                elif name == "force_ref_n":
                    values = np.where(mode == MODE_FORCE, values, np.nan)
                columns[column] = values
    assert list(columns) == csv_header(fingers)
    return Table(path=Path("live"), columns=columns, units={c: unit_of(c, fingers) for c in columns},
                 fingers=list(fingers))


@dataclass(frozen=True)
class KnownRing:
    """A ring given outright (bench --foxglove: no daemon, no socket to ask)."""

    path: str
    fingers: list[str]
    rate_hz: float


class Publisher:
    """The ring's rows -> Foxglove channels. run() until stop(). The ring is the daemon's
    (its status names it) or, with `ring`, one given outright."""

    def __init__(self, link: DaemonLink | None, port: int, with_daemon: int | None = None,
                 ring: KnownRing | None = None) -> None:
        import foxglove

        self._foxglove = foxglove
        self.link = link
        self.server = foxglove.start_server(name="hand-service", host=HOST, port=port)
        self.port = self.server.port
        self.with_daemon = with_daemon
        self.rows_published = 0
        self._ring = RingFollower()
        self._fingers: list[str] = []
        self._channels: list[tuple[ChannelSpec, Any]] = []
        self._offset_ns: int | None = None  # wall clock minus the ring's t, set when attached
        self._stop = threading.Event()
        self.ring = ring

    def stop(self) -> None:
        self._stop.set()

    def run(self) -> None:
        from hand_service.view.beside import alive

        next_status = 0.0
        period_s = 1.0 / POLL_HZ
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                if now >= next_status:
                    if self.with_daemon is not None and not alive(self.with_daemon):
                        break
                    self._poll_status()
                    next_status = now + STATUS_EVERY_S
                self._publish_new()
                self._stop.wait(period_s)
        finally:
            self._detach()
            self.server.stop()

    def _poll_status(self) -> None:
        if self.ring is not None:
            status = {"recording": {"active": True, "ring_path": self.ring.path},
                      "rate_hz": self.ring.rate_hz, "fingers": dict.fromkeys(self.ring.fingers)}
        else:
            status = self._daemon_status()
        if status is not None:
            self._attach(status)

    def _daemon_status(self) -> dict[str, Any] | None:
        assert self.link is not None
        try:
            return self.link.status()
        except (ApiError, ConnectionError) as exc:
            log.warning("foxglove: the daemon cannot be reached: %s", exc)
            self._detach()
            return None

    def _attach(self, status: dict[str, Any]) -> None:
        rec = status.get("recording", {})
        path = rec.get("ring_path") if rec.get("active") else None
        if not self._ring.follow(path, float(status.get("rate_hz", 100.0))):
            if self._ring.note is not None and self._ring.tap is None and path is not None:
                log.warning("foxglove: %s", self._ring.note)
            return
        fingers = list(status.get("fingers", {}))
        # wall clock minus t: from the status's t, or (a ring given outright) the first rows read
        t_s = None if self.ring is not None else float(status["t_s"])
        self._offset_ns = None if t_s is None else time.time_ns() - round(t_s * 1e9)
        if fingers != self._fingers or not self._channels:
            self._advertise(fingers)

    def _advertise(self, fingers: list[str]) -> None:
        for _spec, channel in self._channels:
            channel.close()
        fox = self._foxglove
        specs = channel_specs(ring_table(np.zeros((1, len(HEAD) + len(QUANTITIES) * len(fingers))), fingers))
        self._channels = [(spec, fox.Channel(spec.topic, message_encoding="json",
                                             schema=fox.Schema(name=spec.schema_name, encoding="jsonschema",
                                                               data=spec.schema_json.encode()),
                                             metadata=spec.metadata)) for spec in specs]
        self._fingers = fingers
        log.info("foxglove: %s", ", ".join(spec.topic for spec, _ in self._channels))

    def _detach(self) -> None:
        self._ring.close()

    def _publish_new(self) -> None:
        got = self._ring.read_new()
        if got is None:
            return
        rows, _first = got
        if not rows.shape[0]:
            return
        if self._offset_ns is None:
            self._offset_ns = time.time_ns() - round(float(rows[-1, 0]) * 1e9)
        table = ring_table(rows, self._fingers)
        cells = table_cells(table)
        times = self._offset_ns + np.round(rows[:, 0] * 1e9).astype(np.int64)
        for row in range(table.rows):
            for spec, channel in self._channels:
                channel.log(spec.message(cells, row), log_time=int(times[row]))
        self.rows_published += table.rows


def main(argv: list[str] | None = None) -> int:
    from hand_service.view.beside import leave_realtime

    parser = argparse.ArgumentParser(prog="python -m hand_service.view.foxglove")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--socket", type=Path, help="the daemon's control socket (its status names the ring)")
    source.add_argument("--ring", help="a recording ring given outright (with --fingers, --rate)")
    parser.add_argument("--fingers", default="", help="with --ring: the fingers, comma-separated")
    parser.add_argument("--rate", type=float, default=100.0, help="with --ring: the rows' rate (Hz)")
    parser.add_argument("--port", type=int, default=DEFAULT_PORT)
    parser.add_argument("--with-daemon", type=int)
    args = parser.parse_args(argv)
    ring = None if args.ring is None else KnownRing(args.ring, args.fingers.split(","), args.rate)
    link = None if args.socket is None else DaemonLink(LinkOptions(args.socket))
    leave_realtime()  # started by run --foxglove after the daemon took SCHED_FIFO
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        publisher = Publisher(link, args.port, args.with_daemon, ring)
    except Exception as exc:  # the SDK's own error type: a port in use, say
        print(f"foxglove: cannot serve on {HOST}:{args.port}: {exc}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, lambda *_: publisher.stop())
    signal.signal(signal.SIGINT, lambda *_: publisher.stop())
    print(f"foxglove: ws://{HOST}:{publisher.port} (Foxglove: Open connection, Foxglove WebSocket; "
          "channels appear while the daemon records)", flush=True)
    publisher.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
