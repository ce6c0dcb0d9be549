"""The reference valve-board firmware's host build (board/), built once per test session
and run as the real binary behind the HIL rig (hand_service/firmware/rig.py), in place of
the Python mock: the same tests, the same host code, a C firmware on the other end."""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
from pathlib import Path

from hand_service.config.profile import Profile
from hand_service.firmware.rig import START_TIMEOUT_S, Rig

REPO = Path(__file__).resolve().parents[2]
BOARD_DIR = REPO / "board"
WIRES = {"serial": "serial", "slcan": "slcan"}  # rig name -> board-host --wire


def build(build_dir: Path) -> Path:
    """`make -C board` into build_dir (the C compiler and cantools' generator): the binary."""
    if shutil.which("make") is None or shutil.which("cc") is None:
        raise RuntimeError("building board/ needs make and a C compiler (cc)")
    python = str(Path(sys.executable))
    result = subprocess.run(["make", "-s", "-C", str(BOARD_DIR), f"BUILD={build_dir}", f"PYTHON={python}"],
                            capture_output=True, text=True, timeout=300)
    if result.returncode != 0:
        raise RuntimeError(f"make -C board failed:\n{result.stdout[-3000:]}{result.stderr[-3000:]}")
    return build_dir / "board-host"


def board_arguments(profile: Profile) -> list[str]:
    """What the host build must know of the profile: the rate, the watchdog, the fingers."""
    return ["--rate-hz", f"{profile.control.rate_hz:g}",
            "--watchdog-ms", f"{profile.safety['firmware_watchdog_ms']:g}",
            "--fingers", str(len(profile.fingers))]


class BoardRig(Rig):
    """A rig whose firmware is board-host on the rig's pty, instead of the Python mock."""

    binary: Path | None = None  # set by the session fixture

    def start_mock(self, protocol_version: int | None = None, firmware_version: str = "1.0.0") -> None:
        assert self.binary is not None, "the board's host build was not built"
        command = [str(self.binary), "--wire", WIRES[self.name], "--port", self.channel,
                   "--firmware-version", firmware_version, *board_arguments(self.profile)]
        if protocol_version is not None:
            command += ["--protocol-version", str(protocol_version)]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        threading.Thread(target=self._collect, args=(self.process,), daemon=True).start()
        self.wait_for_line(r"^ready: ", START_TIMEOUT_S)
