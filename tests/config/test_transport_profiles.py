"""The bus profiles load; every kind of mistake in a transport section is one clear line."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hand_service.config.profile import PROFILE_DIR, load_profile
from hand_service.errors import UserError

CAN = (PROFILE_DIR / "can-v1.yaml").read_text()
SERIAL = (PROFILE_DIR / "serial-v1.yaml").read_text()

MISTAKES = [
    (CAN, "interface: socketcan", "interface: sockecan",
     r"transport.interface must be one of .*not 'sockecan'"),
    (CAN, "bitrate_bps: 500000", "bitrate_bps: 5000000",
     r"transport.bitrate_bps = 5e\+06 bit/s is out of range"),
    (CAN, "  channel: can0\n", "", r"missing required key 'transport.channel'"),
    (CAN, "dbc: can-v1.dbc", "dbc: can-v9.dbc", r"transport.dbc: .*can-v9.dbc: DBC file not found"),
    (CAN, "dbc: can-v1.dbc", "dbc: broken.dbc",
     r"transport.dbc: .*broken.dbc: the DBC has no message 'SensorFinger'"),
    (CAN, "interface: socketcan", "interface: slcan\n  tty_baudrate_bps: 115200",
     None),  # see test_slcan_needs_an_slcan_bit_rate
    (CAN, "reconnect_backoff_min_ms: 50", "reconnect_backoff_min_ms: 5000",
     r"reconnect_backoff_min_ms must not exceed reconnect_backoff_max_ms"),
    (CAN, "sensor_max_mv: 5000", "sensor_max_mv: -5", r"sensor_min_mv must be below sensor_max_mv"),
    (CAN, "stuck_samples: 25", "stuck_samples: 2.5", r"transport.stuck_samples must be a whole number"),
    (CAN, "stuck_samples: 25", "stuck_samples: 25\n  raw_log: traffic.txt",
     r"transport.raw_log must end in one of .asc, .blf"),
    (CAN, "  channel: can0", "  chanel: can0",
     r"unknown key 'chanel' in transport \(did you mean 'channel'\?\)"),
    (SERIAL, "  port: /dev/ttyACM0\n", "", r"missing required key 'transport.port'"),
    (SERIAL, "baudrate_bps: 921600", "baudrate_bps: fast", r"transport.baudrate_bps must be a number"),
    (SERIAL, "include: sim.yaml", "include: nowhere.yaml", r"include: .*nowhere.yaml not found"),
    (SERIAL, "include: sim.yaml\n", "", r"missing required key 'hand'"),
]
SLCAN_MISTAKE = MISTAKES.pop(5)


def _write(tmp_path: Path, text: str) -> Path:
    for name in ("sim.yaml", "can-v1.dbc"):
        shutil.copy(PROFILE_DIR / name, tmp_path / name)
    (tmp_path / "broken.dbc").write_text('VERSION ""\n\nNS_ :\n\nBS_:\n\nBU_:\n')
    path = tmp_path / "profile.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(("text", "old", "new", "message"), MISTAKES, ids=[m[3][:40] for m in MISTAKES])
def test_transport_mistakes_are_one_clear_line(tmp_path: Path, text: str, old: str, new: str,
                                               message: str) -> None:
    assert old in text, old
    path = _write(tmp_path, text.replace(old, new, 1))
    with pytest.raises(UserError, match=message) as info:
        load_profile(path)
    assert "\n" not in str(info.value)
    assert str(path) in str(info.value)


def test_slcan_needs_an_slcan_bit_rate(tmp_path: Path) -> None:
    text, old, new, _ = SLCAN_MISTAKE
    text = text.replace("bitrate_bps: 500000", "bitrate_bps: 400000").replace(old, new)
    with pytest.raises(UserError, match=r"transport.bitrate_bps = 400000 is not an SLCAN rate"):
        load_profile(_write(tmp_path, text))


def test_included_sections_are_the_included_profiles(tmp_path: Path) -> None:
    profile = load_profile(PROFILE_DIR / "can-v1.yaml")
    sim = load_profile(PROFILE_DIR / "sim.yaml")
    assert profile.finger_names == sim.finger_names
    assert profile.safety == sim.safety and profile.simulation == sim.simulation
    assert Path(profile.transport["dbc"]).is_absolute()
    # a section given in the including file wins over the included one
    path = _write(tmp_path, CAN + "\ncontrol:\n  rate_hz: 200\n")
    assert load_profile(path).control.rate_hz == 200


def test_an_error_in_the_included_profile_names_that_file(tmp_path: Path) -> None:
    path = _write(tmp_path, CAN)
    sim = tmp_path / "sim.yaml"
    sim.write_text(sim.read_text().replace("rate_hz: 100", "rate_hz: 5"))
    with pytest.raises(UserError, match=r"sim.yaml:\d+: control.rate_hz = 5 Hz is out of range"):
        load_profile(path)
