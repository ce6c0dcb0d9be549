"""The firmware's inner pressure loop over the wire: a 0 -> 60 kPa setpoint step on every
chamber, answered sample by sample as the host does, against the host build's physical
pneumatics. Each chamber must settle within 3 kPa of the setpoint (the regulator's
deadband, the sensor's noise) and stay there; what the step measured is printed (marker
`board`: make test-board-host)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from tests.board.firmware import BoardRig

SETPOINT_KPA = 60.0


@pytest.mark.board
def test_pressure_step_settles_at_the_setpoint(tmp_path: Path, board_binary: Path) -> None:
    with BoardRig("serial", tmp_path) as rig:
        rig.binary = board_binary
        rig.start_mock()
        transport = rig.transport()
        transport.open()
        command = np.full(transport.n_fingers, SETPOINT_KPA)
        times: list[float] = []
        pressures: list[np.ndarray] = []
        start = time.monotonic()
        while time.monotonic() - start < 1.5:
            sample = transport.latest()
            if sample is None:
                time.sleep(0.001)
                continue
            transport.send(command)
            times.append(sample.received_s - start)
            pressures.append(sample.pressure_meas_kpa.copy())
        transport.send(np.zeros(transport.n_fingers))
    t = np.array(times)
    p = np.array(pressures)
    settled = p[t > 1.0]
    assert len(settled) > 20, len(settled)
    assert np.all(np.abs(settled.mean(axis=0) - SETPOINT_KPA) < 3.0), settled.mean(axis=0)
    assert np.all(np.abs(settled - SETPOINT_KPA) < 6.0), np.abs(settled - SETPOINT_KPA).max()
    index = p[:, 1]
    t10 = t[np.argmax(index > 0.1 * SETPOINT_KPA)]
    t90 = t[np.argmax(index > 0.9 * SETPOINT_KPA)]
    print(f"\nindex chamber, 0 -> {SETPOINT_KPA:g} kPa: 10 % at {1e3 * t10:.0f} ms, "
          f"90 % at {1e3 * t90:.0f} ms after the first command; settled mean {settled[:, 1].mean():.2f} kPa, "
          f"sd {settled[:, 1].std():.2f} kPa over the last 0.5 s")
