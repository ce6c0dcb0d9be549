"""The reference firmware's C parts: the core's and the plant's C tests under ASan and
UBSan (make -C board test-core), the host build's command line, and the host build's
default hand against the shipped profile it stands for."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from hand_service.config.profile import PROFILE_DIR, load_profile
from tests.board.firmware import BOARD_DIR


def test_core_and_plant_c_tests_pass_under_sanitizers(tmp_path: Path) -> None:
    command = ["make", "-s", "-C", str(BOARD_DIR), f"BUILD={tmp_path}", f"PYTHON={sys.executable}",
               "test-core"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    for name in ("test-core", "test-release", "test-plant"):
        assert f"{name}: all passed" in result.stdout


def test_help_explains_and_bad_input_is_one_line(board_binary: Path, tmp_path: Path) -> None:
    shown = subprocess.run([str(board_binary), "--help"], capture_output=True, text=True, timeout=10)
    assert shown.returncode == 0 and "--wire serial|slcan" in shown.stdout and "ready: PATH" in shown.stdout
    port = str(tmp_path / "p")
    for args, message in [(["--wire", "can", "--port", port], "--wire must be serial or slcan"),
                          (["--port", port, "--rate-hz", "fast"], "--rate-hz must be"),
                          (["--port", port, "--firmware-version", "1.2"], "--firmware-version"),
                          (["--fingers", "3"], "--port PATH is required"),
                          (["--port", str(tmp_path)], "cannot create the pseudo-terminal")]:
        result = subprocess.run([str(board_binary), *args], capture_output=True, text=True, timeout=10)
        assert result.returncode == 2, (args, result)
        assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr


def _default_hand() -> dict[str, list[float]]:
    """The rows of board/host/hand_default.c, by finger name."""
    text = (BOARD_DIR / "host" / "hand_default.c").read_text()
    rows = re.findall(r"\{([-0-9.e, ]+)\},\s*/\* (\w+) \*/", text)
    return {name: [float(x) for x in row.split(",")] for row, name in rows}


@pytest.mark.parametrize("profile_name", ["serial-v1.yaml", "can-v1-slcan.yaml"])
def test_default_hand_is_the_shipped_profiles_hand(profile_name: str) -> None:
    profile = load_profile(PROFILE_DIR / profile_name)
    hand = _default_hand()
    assert list(hand) == profile.finger_names
    for finger in profile.fingers:
        model = finger.model
        expected = [model.mass_kg, model.length_m, model.gamma, model.stiffness_nm_per_rad,
                    model.damping_nms_per_rad, model.pressure_gain_nm_per_kpa,
                    finger.sensor_gain_deg_per_mv, finger.sensor_offset_deg]
        assert hand[finger.name] == pytest.approx(expected, rel=1e-9), finger.name
