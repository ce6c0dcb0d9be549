"""The tick's ring row, built in C from the control step's structs, lands in the columns
the writer names (recorder_writer.QUANTITIES); a reader never keeps a torn row, and counts and
publishes the rows it lost."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

import rtcore
from hand_service.config.profile import load_profile
from hand_service.service.recorder_writer import HEAD, QUANTITIES, Drainer
from rtcore._rtcore import ffi
from rtcore.ring import Ring


def test_push_tick_matches_the_writer_layout(tmp_path: Path) -> None:
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    n = len(profile.fingers)
    sent = np.arange(n) + 100.0
    truth = np.arange(n) + 20.5  # the simulated hand's true angles
    ring = Ring(tmp_path / "ring", len(HEAD) + len(QUANTITIES) * n, 16)
    push_tick = ring.tick_pusher(n, hand.c_inputs, hand.c_outputs, sent,
                                 ffi.cast("double *", ffi.from_buffer(truth)))
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
        "force_est_n": hand.outputs.force_normal_n, "force_ref_n": hand.inputs.force_ref_n,
        "mode": hand.inputs.mode, "flags": hand.outputs.flags, "angle_true_deg": truth,
    }
    assert set(expected) == set(QUANTITIES)
    for k, name in enumerate(QUANTITIES):
        block = row[len(HEAD) + k * n: len(HEAD) + (k + 1) * n]
        np.testing.assert_array_equal(block, np.asarray(expected[name], dtype=float), err_msg=name)
    ring.close()


def _ring_and_pusher(tmp_path: Path, capacity: int) -> tuple[Ring, object, rtcore.Hand]:
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    n = len(profile.fingers)
    ring = Ring(tmp_path / "ring", len(HEAD) + len(QUANTITIES) * n, capacity)
    return ring, ring.tick_pusher(n, hand.c_inputs, hand.c_outputs, np.zeros(n)), hand


def test_a_reader_never_takes_the_row_being_overwritten(tmp_path: Path) -> None:
    """The producer writes row n into the slot of row n - capacity before it publishes
    n + 1: a reader that sees the count n must count that row lost, not copy it torn."""
    ring, push, _ = _ring_and_pusher(tmp_path, 4)
    for k in range(6):
        push(float(k), 0)
    # row 6 is half written into slot 6 % 4 = 2, where row 2 was; the count still says 6
    ring.rows[6 % 4, :5] = -1.0
    block, first, lost = ring.read(2)
    assert (first, lost) == (3, 1)
    np.testing.assert_array_equal(block[:, 0], [3.0, 4.0, 5.0])
    assert not (block == -1.0).any()
    ring.close()


def test_rows_lost_to_a_stalled_reader_are_counted_and_published(tmp_path: Path) -> None:
    ring, push, _ = _ring_and_pusher(tmp_path, 16)
    out = io.StringIO()
    drainer = Drainer(ring, out, load_profile().finger_names)
    for k in range(40):  # the writer stalled while 40 rows were pushed into 16 slots
        push(k / 100, 3)
    assert drainer.drain() == 15  # the 15 whole rows below the count
    assert drainer.rows_lost == 25 and ring.lost == 25  # in the header, for the daemon
    assert ring.drained == 40
    text = out.getvalue()
    assert text.startswith("# lost: 25 rows before row 25")
    assert text.splitlines()[1].startswith("0.2500,RUNNING")
    for k in range(40, 45):
        push(k / 100, 3)
    assert drainer.drain() == 5 and ring.lost == 25  # caught up: nothing more lost
    ring.close()
