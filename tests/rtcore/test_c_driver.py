"""Build the plain-C test driver and run it, normally and under ASan + UBSan."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from rtcore._build import BOARD_DIRS, GENERATED, generate_can_v1

ROOT = Path(__file__).resolve().parents[2]
CSRC = ROOT / "csrc"
# rtcore_can.c wraps the can-v1 pack/unpack cantools generates from the DBC (build/gen/)
SOURCES = [str(p) for p in [*sorted(CSRC.glob("rtcore_*.c")), *sorted((CSRC / "test").glob("*.c")),
                            generate_can_v1()]]
INCLUDES = [f"-I{CSRC}", *(f"-I{ROOT / name}" for name in BOARD_DIRS), f"-I{GENERATED}"]
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic"]
BUILDS = {
    "optimised": ["-O2"],
    "sanitized": ["-O0", "-g", "-fno-omit-frame-pointer", "-fsanitize=address,undefined",
                  "-fno-sanitize-recover=all"],
}


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
# the sanitized build in make test, the optimised one in test-thorough
@pytest.mark.parametrize("build", [pytest.param("optimised", marks=pytest.mark.thorough), "sanitized"])
def test_c_driver(tmp_path: Path, build: str) -> None:
    binary = tmp_path / f"test_rtcore_{build}"
    compile_cmd = ["gcc", *STRICT, *BUILDS[build], *INCLUDES, *SOURCES, "-lm", "-o", str(binary)]
    built = subprocess.run(compile_cmd, capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    ran = subprocess.run([str(binary)], capture_output=True, text=True, timeout=300,
                         env={"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=1",
                              "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"})
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert " 0 failures" in ran.stdout
    assert "runtime error" not in ran.stderr
