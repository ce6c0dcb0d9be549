"""The daemon: the supervisor with its control API, recording, live status line and
systemd notifications, wired together for `hand-service run`. The one place above the
service and the API that makes a supervisor (tests/test_supervisor_surface.py); everything
else it does goes through the supervisor's surface (service/surface.py)."""

from __future__ import annotations

import logging
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from hand_service.api.paths import SETS_IT, choose_data_dir, prepare_record_dir
from hand_service.api.requests import Api
from hand_service.api.server import ApiServer
from hand_service.app.status_line import EndBeforeLog, StatusLine
from hand_service.config.profile import Profile
from hand_service.service.factory import supervisor
from hand_service.service.recorder import Recorder
from hand_service.service.sdnotify import Notifier
from hand_service.service.states import State
from hand_service.service.surface import TickLoop
from hand_service.service.timing import Realtime, setup_realtime, switch_interval
from hand_service.transports import Transport
from hand_service.version import software_version
from rtcore import clock

log = logging.getLogger(__name__)

STATUS_EVERY_S = 0.25
API_SHARE = 0.25  # of each period, at most, for the control API's requests


@dataclass
class DaemonOptions:
    socket_path: Path | None = None
    tcp_port: int | None = None
    record: Path | None = None
    record_dir: Path | None = None  # run --data-dir: requests' paths lie in it (paths.choose_data_dir)
    recorder: str = "process"
    record_sync_s: float | None = None  # the writer also fdatasyncs this often
    spin_us: float = 0.0
    realtime_priority: int | None = None
    lock_memory: bool = False
    status_line: bool = False
    seed: int | None = None


class Daemon:
    def __init__(self, profile: Profile, transport: Transport, options: DaemonOptions,
                 out: TextIO | None = None) -> None:
        self.profile, self.options = profile, options
        self.out = out or sys.stdout
        recorder = Recorder(profile.finger_names, profile.control.rate_hz, options.recorder,
                            options.record_sync_s, profile.recording.file_mode_bits)
        self.transport = transport
        self.sup: TickLoop = supervisor(profile, transport, recorder, spin_us=options.spin_us)
        self.api = Api(self.sup, self.metadata)
        self.server = ApiServer(self.api.handle, options.socket_path, options.tcp_port)
        self.notifier = Notifier()
        self.realtime = Realtime()
        self._status_every = max(1, round(STATUS_EVERY_S * self.sup.rate_hz))
        self._notify_every = max(1, round(1.0 * self.sup.rate_hz))
        self.line = StatusLine(self.out)
        self._ready_sent = False
        self._estop_signalled = False  # SIGUSR1: ESTOP in the slack after the next tick
        self.sup.add_slack(self._slack)
        self.sup.on_state_change(self._state_changed)

    def metadata(self) -> dict[str, object]:
        """Provenance for the `#` lines of every recording."""
        prof = self.profile
        seed = self.options.seed if self.options.seed is not None else prof.simulation.get("seed")
        meta: dict[str, object] = {
            "profile": f"{prof.name} ({prof.path})",
            "software_version": software_version(),
            "transport": prof.transport["kind"],
            "sample_rate_hz": f"{self.sup.rate_hz:g}",
            "fingers": " ".join(prof.finger_names),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        if prof.transport["kind"] == "sim":
            meta["seed"] = seed
        return meta

    def open(self) -> None:
        """Everything that may fail with a clear message, before the loop starts; a start
        that fails removes the socket and token file it made."""
        try:
            self.server.open()
            if self.server.listening:  # the directory requests record to and load from
                chosen, why = choose_data_dir(self.options.record_dir, self.profile.recording.data_dir,
                                              self.options.record)
                self.api.record_dir = prepare_record_dir(chosen)
                self.out.write(f"data directory: {self.api.record_dir} ({why}; `ctl load` and "
                               f"`ctl record-start` use files only here; {SETS_IT})\n")
            if self.options.record is not None:
                self.sup.start_recording(self.options.record, self.metadata())
        except BaseException:
            self.server.close()
            raise
        self.realtime = setup_realtime(self.options.realtime_priority, self.options.lock_memory)
        log.info("%s at %g Hz, %s; realtime: %s", self.profile.name, self.sup.rate_hz,
                 self.profile.transport["kind"], self.realtime.describe())

    def run(self, duration_s: float | None = None, install_signals: bool = True) -> dict[str, Any]:
        old_usr1 = None
        end_before_log = EndBeforeLog(self.line)
        end_before_log.attach()
        if install_signals:
            self.sup.install_signal_handlers()
            old_usr1 = signal.signal(signal.SIGUSR1, self._sigusr1)
        try:
            with switch_interval():  # the I/O and worker threads yield the GIL to the tick soon
                self.sup.run(duration_s)
        finally:
            if old_usr1 is not None:
                signal.signal(signal.SIGUSR1, old_usr1)
            self.notifier.stopping()
            self.server.close()
            end_before_log.detach()
            self.line.end()
            self.notifier.close()
        return self.summary()

    # -- signals and slack ---------------------------------------------------------------
    def _sigusr1(self, _signum: int, _frame: object) -> None:
        """The out-of-band E-stop, for when no client can reach the API: only a flag here
        (a handler may run in the middle of a tick's Python); the slack acts on it."""
        self._estop_signalled = True

    def _estop_if_signalled(self) -> None:
        if self._estop_signalled:
            self._estop_signalled = False
            log.warning("SIGUSR1: emergency stop (%s -> ESTOP)", self.sup.state.name)
            self.sup.estop()

    def api_budget_ns(self, slack_ns: int) -> int:
        """The API's work per poll: a share of the period, and at most half of what is left
        of it (the server serves every urgent request and one other beyond it)."""
        return max(0, min(int(API_SHARE * self.sup.period_ns), slack_ns // 2))

    def _slack(self, slack_ns: int) -> None:
        self._estop_if_signalled()
        self.api.poll()
        self.server.poll(self.api_budget_ns(slack_ns))
        self._estop_if_signalled()  # a signal during the poll: not a tick later
        ticks = self.sup.ticks_run
        self.notifier.watchdog(clock.now_ns())
        if ticks % self._status_every == 0 and self.options.status_line:
            self.line.show(self.status_text())
        if ticks % self._notify_every == 0 and self.notifier.enabled:
            self.notifier.status(self.status_text())

    def _state_changed(self, state: State) -> None:
        if state is State.DISARMED and not self._ready_sent:
            self._ready_sent = True
            self.notifier.ready(f"{self.profile.name}: DISARMED")

    def status_text(self) -> str:
        status = self.sup.status()
        err = [abs(f.angle_filt_deg - f.angle_ref_deg) for f in status.fingers.values()
               if f.mode == "position" and f.angle_ref_deg is not None]
        error = f"max |err| {max(err):5.2f} deg" if err else "max |err|   -     "
        recent = self.sup.timing(last=int(self.sup.rate_hz))
        return (f"t {status.t_s:7.2f} s {status.state.name:<8} {error} | tick p50 "
                f"{recent.get('tick_ns_p50', 0) / 1e3:5.0f} us | jitter p99 "
                f"{recent.get('jitter_us_p99', 0) / 1e3:5.2f} ms | misses "
                f"{recent['deadline_misses']} | faults "
                f"{status.faults.total}{recording_text(status.recording)}")

    def summary(self) -> dict[str, Any]:
        return {**self.sup.summary(), "realtime": self.realtime.describe()}


def recording_text(recording: dict[str, Any]) -> str:
    """The recording's part of the status line: its rows, or FAILED and the rows lost."""
    if not recording["active"]:
        return ""
    if recording["failure"] is None:
        return f" | rec {recording['rows']} rows"
    return f" | rec FAILED ({recording['failure']['reason']}): {recording['rows_lost']} rows lost"


def print_summary(summary: dict[str, Any], out: TextIO) -> None:
    out.write(f"stopped ({summary['stop_reason']}) in {summary['state']} after {summary['ticks']} ticks\n")
    if summary["ticks"]:
        out.write(f"  tick     p50 {summary['tick_ns_p50'] / 1e3:7.1f} us   p99 "
                  f"{summary['tick_ns_p99'] / 1e3:7.1f} us   max {summary['tick_ns_max'] / 1e3:7.1f} us\n")
        if "tick_return_ns_p50" in summary:  # the tick ended in C (the simulated hand)
            out.write(f"  back in Python p50 {summary['tick_return_ns_p50'] / 1e3:5.1f} us   p99 "
                      f"{summary['tick_return_ns_p99'] / 1e3:7.1f} us (after a tick that ended in C)\n")
        out.write(f"  jitter   p50 {summary['jitter_us_p50']:7.1f} us   p99 "
                  f"{summary['jitter_us_p99']:7.1f} us   max {summary['jitter_us_max']:7.1f} us\n")
        out.write(f"  deadline misses {summary['deadline_misses']} ({summary['deadline_misses_woke_late']} "
                  f"woke after their period), skipped deadlines "
                  f"{summary['skipped_deadlines']}, gc collections in the slack "
                  f"{summary['gc_collections']} (max {summary['gc_collect_ns_max'] / 1e3:.0f} us)\n")
    faults = summary["faults"]
    out.write("  faults: " + (", ".join(f"{k} x{v}" for k, v in faults.items()) if faults else "none") + "\n")
    out.write(f"  realtime: {summary['realtime']}\n")
