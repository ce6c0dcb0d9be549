"""A real daemon recording for the export and CSV-format tests: `hand-service run` on the
simulated hand, armed and moved through its control socket, then stopped (about 5 s)."""

from __future__ import annotations

import time
from pathlib import Path

from tests.service.process import DaemonProcess, wait_for

# every column of the daemon's recording per finger, with the unit docs/formats.md §1.3 gives it
DAEMON_UNITS = {"angle_ref_deg": "deg", "pressure_kpa": "kPa", "pressure_meas_kpa": "kPa",
                "angle_deg": "deg", "angle_filt_deg": "deg", "velocity_deg_per_s": "deg/s",
                "force_est_n": "N", "force_ref_n": "N", "mode": "", "flags": "", "angle_true_deg": "deg"}


def record_daemon(tmp: Path, running_s: float = 1.5) -> Path:
    """Disarmed, then armed with the index finger in position mode and the thumb in force
    mode (text columns, NaN references, integer flags all present), then SIGTERM."""
    daemon = DaemonProcess(tmp, "--duration", "60")
    try:
        with daemon.client() as hand:
            daemon.disarmed(hand)
            hand.arm()
            hand.target("index", angle_deg=40.0)
            hand.target("thumb", force_n=0.5)
            hand.start()
            wait_for(lambda: hand.status()["state"] == "RUNNING", 10.0, "RUNNING")
            time.sleep(running_s)
        assert daemon.terminate(20.0) == 0, daemon.stderr.read_text()[-2000:]
    finally:
        daemon.close()
    return daemon.record
