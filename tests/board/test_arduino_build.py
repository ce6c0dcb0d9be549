"""The Arduino sketch (board/arduino/valve_board/: the firmware core with the Arduino core as
its hardware layer) builds from Debian's arduino-core-avr with avr-gcc/avr-g++ for an Arduino
Nano, with -Wall -Wextra -Werror on the project's sources, and fits the ATmega328P; the build
refuses an image over either limit and a sketch with a warning. Run by `make test-board`
(marker `qemu`), which installs arduino-core-avr, gcc-avr and avr-libc."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.qemu

REPO = Path(__file__).resolve().parents[2]
SKETCH = REPO / "board" / "arduino" / "valve_board" / "valve_board.ino"
ARDUINO_CORE = Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino")
FIT = re.compile(r"arduino-nano: flash (\d+) of (\d+) bytes, static RAM (\d+) of (\d+) bytes")
FLASH_BYTES = 32 * 1024 - 512  # the ATmega328P's flash less the Uno's (optiboot's) bootloader
RAM_BYTES = 2 * 1024
STACK_RESERVE_BYTES = 512


def make_arduino(build_dir: Path, *overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["make", "-s", "-C", str(REPO / "board"), f"BUILD={build_dir}",
                           f"PYTHON={sys.executable}", *overrides, "arduino"],
                          capture_output=True, text=True, timeout=300)


def test_sketch_builds_on_the_arduino_core_and_fits_the_nano(tmp_path: Path) -> None:
    for tool in ("avr-gcc", "avr-g++", "avr-size", "make"):
        if shutil.which(tool) is None:
            pytest.fail(f"{tool} is missing: `make test-board` installs it")
    if not (ARDUINO_CORE / "Arduino.h").exists():
        pytest.fail(f"{ARDUINO_CORE} is missing: `make test-board` installs arduino-core-avr")
    result = make_arduino(tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    match = FIT.search(result.stdout)
    assert match, result.stdout
    flash, flash_max, ram, ram_max = (int(x) for x in match.groups())
    print(f"\n{match.group(0)} (the chip's {RAM_BYTES} less {STACK_RESERVE_BYTES} for the stack)")
    assert (flash_max, ram_max) == (FLASH_BYTES, RAM_BYTES - STACK_RESERVE_BYTES)
    assert 0 < flash <= flash_max and 0 < ram <= ram_max
    elf = tmp_path / "arduino" / "valve_board.elf"
    hex_lines = (tmp_path / "arduino" / "valve_board.hex").read_text().splitlines()
    assert hex_lines[0].startswith(":") and hex_lines[-1] == ":00000001FF"  # Intel HEX, for avrdude

    # the Arduino core is the hardware layer: its Serial, micros() and main() (which calls the
    # sketch's setup and loop) are linked, the firmware core beside them, and no heap
    symbols = set(subprocess.run(["avr-nm", "-C", str(elf)], capture_output=True, text=True,
                                 check=True).stdout.split())
    assert {"Serial", "micros", "main", "setup", "loop", "board_poll", "board_init", "hal_time_us"} <= symbols
    assert not {"malloc", "free", "__brkval"} & symbols

    # the check bites: a limit one byte under the image's use fails the link and leaves no image
    for override in (f"ARDUINO_RAM_MAX={ram - 1}", f"ARDUINO_FLASH_MAX={flash - 1}"):
        elf.unlink(missing_ok=True)  # the objects stay: only the link and the check run again
        over = make_arduino(tmp_path, override)
        assert over.returncode != 0 and "arduino-nano: the image does not fit" in over.stderr, override
        assert not elf.exists(), override

    # -Werror on the sketch: a warning (an unused variable) fails its build
    warned = tmp_path / "warned" / "valve_board.ino"
    warned.parent.mkdir()
    loop_body = "void loop()\n{\n"
    warned.write_text(SKETCH.read_text().replace(loop_body, loop_body + "    int unused_count;\n"))
    assert "unused_count" in warned.read_text()
    failed = make_arduino(tmp_path, f"SKETCH={warned}")
    assert failed.returncode != 0 and "unused_count" in failed.stderr and "-Werror" in failed.stderr, \
        failed.stderr[-2000:]
