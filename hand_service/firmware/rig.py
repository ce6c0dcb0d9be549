"""The C board (board/core) standing in for a valve board, and the way to reach it, for each
of the three tested links (`mock-firmware` is the command that runs it on this host):

    virtual  can-v1-virtual.yaml  python-can virtual bus; the board runs in a thread (cffi)
    slcan    can-v1-slcan.yaml    SLCAN on a pty; the board runs in another process
    serial   serial-v1.yaml       serial-v1 on a pty; the board runs in another process

Each rig gets its own channel (a fresh virtual channel name, or a pty path in its own
directory) and ends everything it started in close(): transports, hosts, the board.
The HIL tests and the I/O benchmarks (bench/io.py) both build on it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path
from typing import Any

from hand_service.config.profile import PROFILE_DIR, Profile, load_profile
from hand_service.firmware.board import BoardThread, run_in_thread
from hand_service.transports import transport_class
from hand_service.transports.link import LinkTransport

RIG_PROFILES = {"virtual": "can-v1-virtual.yaml", "slcan": "can-v1-slcan.yaml", "serial": "serial-v1.yaml"}
VENT_LINE = re.compile(r"watchdog: .*vented every valve \(t_monotonic_s=([0-9.]+)\)")
START_TIMEOUT_S = 60.0


class RigError(RuntimeError):
    pass


class Rig:
    def __init__(self, name: str, workdir: Path, profile: Profile | None = None,
                 board_priority: int | None = None) -> None:
        self.name = name
        # the mock process's SCHED_FIFO priority (None: the normal scheduler): a board is an MCU
        # that the PC's load never delays, which a soak beside the test suite wants
        self.board_priority = board_priority
        # the mock process loads the profile from its file: the given one's, or the shipped one
        self.profile_path = profile.path if profile is not None else PROFILE_DIR / RIG_PROFILES[name]
        self.profile = profile or load_profile(self.profile_path)
        if name == "virtual":
            self.channel = f"hil-{uuid.uuid4().hex[:12]}"
        else:
            self.channel = str(Path(workdir) / f"{name}.pty")
        self.option = "port" if self.profile.transport["kind"] == "serial" else "channel"
        self.mock: BoardThread | None = None
        self.process: subprocess.Popen[str] | None = None
        self.lines: list[str] = []
        self._lines_lock = threading.Lock()
        self._transports: list[LinkTransport] = []
        self._hosts: list[subprocess.Popen[str]] = []

    @staticmethod
    def name_for(profile: Profile) -> str | None:
        """The rig that can mock this profile's firmware, or None (a real bus: socketcan...)."""
        settings = profile.transport
        if settings["kind"] == "serial":
            return "serial"
        if settings["kind"] == "can" and settings["interface"] in ("slcan", "virtual"):
            return str(settings["interface"])
        return None

    @property
    def in_process(self) -> bool:
        return self.name == "virtual"

    # -- the mock firmware -----------------------------------------------------------------

    def start_mock(self, protocol_version: int | None = None, firmware_version: str = "1.0.0") -> None:
        if self.in_process:
            version = tuple(int(x) for x in firmware_version.split("."))
            self.mock = run_in_thread(self.profile, self.channel, protocol_version=protocol_version,
                                      firmware_version=version)
            return
        command = [sys.executable, "-m", "hand_service.cli", "mock-firmware", "--profile",
                   str(self.profile_path), "--port", self.channel, "--firmware-version", firmware_version]
        if protocol_version is not None:
            command += ["--protocol-version", str(protocol_version)]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if self.board_priority is not None:  # before its interpreter starts the threads that inherit it
            os.sched_setscheduler(self.process.pid, os.SCHED_FIFO, os.sched_param(self.board_priority))
        threading.Thread(target=self._collect, args=(self.process,), daemon=True).start()
        self.wait_for_line(r"^ready: ", START_TIMEOUT_S)

    def _collect(self, process: subprocess.Popen[str]) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            with self._lines_lock:
                self.lines.append(line.rstrip("\n"))

    def wait_for_line(self, pattern: str, timeout_s: float, start: int = 0) -> re.Match[str]:
        """The first line of the mock's output (from index `start`) matching `pattern`."""
        regex = re.compile(pattern)
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            with self._lines_lock:
                lines = list(self.lines[start:])
            for line in lines:
                match = regex.search(line)
                if match:
                    return match
            if self.process is not None and self.process.poll() is not None:
                raise RigError(f"mock firmware exited ({self.process.returncode}): {self.lines[-5:]}")
            time.sleep(0.01)
        raise RigError(f"no line matching {pattern!r} from the mock within {timeout_s} s: {self.lines[-5:]}")

    def vent_times_s(self) -> list[float]:
        """Monotonic time (the machine's, shared by every process) of each watchdog vent."""
        if self.mock is not None:
            return list(self.mock.firmware.vent_times_s)
        with self._lines_lock:
            return [float(m.group(1)) for line in self.lines if (m := VENT_LINE.search(line))]

    # -- hosts -----------------------------------------------------------------------------

    def transport(self, **options: Any) -> LinkTransport:
        transport = transport_class(self.profile.transport["kind"])(
            self.profile, **{self.option: self.channel, **options})
        self._transports.append(transport)  # type: ignore[arg-type]
        return transport  # type: ignore[return-value]

    def start_host(self, pressure_kpa: float) -> subprocess.Popen[str]:
        """A host process holding `pressure_kpa` (hold.py); returns once it holds."""
        process = subprocess.Popen(
            [sys.executable, "-m", "hand_service.firmware.hold", "--profile", str(self.profile_path),
             "--option", f"{self.option}={self.channel}", "--pressure-kpa", str(pressure_kpa)],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        self._hosts.append(process)
        assert process.stdout is not None
        line = process.stdout.readline()
        if line.strip() != "holding":
            process.kill()
            raise RigError(f"the host did not start holding (exit {process.wait()})")
        return process

    def close(self) -> None:
        for transport in self._transports:
            transport.close()
        for process in [*self._hosts, *([self.process] if self.process else [])]:
            if process.poll() is None:
                process.terminate()
                try:
                    process.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait(timeout=5)
        if self.mock is not None:
            self.mock.stop()
            self.mock = None

    def __enter__(self) -> Rig:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
