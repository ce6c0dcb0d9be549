"""The tick's ring row, built in C from the control step's structs, lands in the columns
the writer names (recwriter.QUANTITIES)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import rtcore
from hand_service.profile import load_profile
from hand_service.recwriter import HEAD, QUANTITIES
from rtcore.ring import Ring


def test_push_tick_matches_the_writer_layout(tmp_path: Path) -> None:
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    n = len(profile.fingers)
    sent = np.arange(n) + 100.0
    ring = Ring(tmp_path / "ring", len(HEAD) + len(QUANTITIES) * n, 16)
    push_tick = ring.tick_pusher(n, hand.c_inputs, hand.c_outputs, sent)
    hand.inputs.mode[:] = rtcore.MODE_POSITION
    hand.inputs.sensor_mv[:] = 900.0 + np.arange(n)
    hand.inputs.pressure_meas_kpa[:] = 50.0 + np.arange(n)
    hand.inputs.angle_ref_deg[:] = 30.0 + np.arange(n)
    hand.inputs.force_ref_n[:] = 0.5 + np.arange(n)
    hand.step()
    assert push_tick(1.25, 4) == 1
    row = ring.rows[0]
    assert row[0] == 1.25 and row[1] == 4.0
    expected = {
        "angle_ref_deg": hand.inputs.angle_ref_deg, "pressure_kpa": sent,
        "pressure_meas_kpa": hand.inputs.pressure_meas_kpa, "angle_deg": hand.outputs.angle_deg,
        "angle_filt_deg": hand.outputs.angle_filt_deg, "velocity_deg_per_s": hand.outputs.velocity_deg_per_s,
        "force_est_n": hand.outputs.force_est_n, "force_ref_n": hand.inputs.force_ref_n,
        "mode": hand.inputs.mode, "flags": hand.outputs.flags,
    }
    assert set(expected) == set(QUANTITIES)
    for k, name in enumerate(QUANTITIES):
        block = row[len(HEAD) + k * n: len(HEAD) + (k + 1) * n]
        np.testing.assert_array_equal(block, np.asarray(expected[name], dtype=float), err_msg=name)
    ring.close()
