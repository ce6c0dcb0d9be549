"""The AVR image (board/avr/: the firmware core on an ATmega328P, Arduino Nano/Uno) builds
with avr-gcc under -Wall -Wextra -Werror and fits the part, and the build refuses an image
that does not. Run by `make test-board` with the QEMU tests (marker `qemu`): it needs
Debian's gcc-avr and avr-libc, which that target installs."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.qemu

REPO = Path(__file__).resolve().parents[2]
FIT = re.compile(r"atmega328p: flash (\d+) of (\d+) bytes, static RAM (\d+) of (\d+) bytes")


def make_avr(build_dir: Path, *overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["make", "-s", "-C", str(REPO / "board"), f"BUILD={build_dir}",
                           f"PYTHON={sys.executable}", *overrides, "avr"],
                          capture_output=True, text=True, timeout=300)


def test_avr_image_builds_and_fits_the_atmega328p(tmp_path: Path) -> None:
    if shutil.which("avr-gcc") is None:
        pytest.fail("avr-gcc is missing: `make test-board` installs it")
    result = make_avr(tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    match = FIT.search(result.stdout)
    assert match, result.stdout
    flash, flash_max, ram, ram_max = (int(x) for x in match.groups())
    print(f"\n{match.group(0)}")
    assert 0 < flash <= flash_max <= 32 * 1024 and 0 < ram <= ram_max <= 2 * 1024
    hex_lines = (tmp_path / "avr" / "handboard.hex").read_text().splitlines()
    assert hex_lines[0].startswith(":") and hex_lines[-1] == ":00000001FF"  # Intel HEX, for avrdude
    # the check bites: an image over the RAM budget fails the build and leaves no image
    over = make_avr(tmp_path / "over", f"AVR_RAM_MAX={ram - 1}")
    assert over.returncode != 0 and "the image does not fit" in over.stderr
    assert not (tmp_path / "over" / "avr" / "handboard.elf").exists()
