"""cppcheck (`make -C board cppcheck`) is clean on everything under board/: the core and the
plant in the test and the release image, the host and the in-process builds, the C tests,
the Cortex-M and AVR ports and the Arduino sketch; and it is live on each of them: a bug
seeded into a copy of each part fails it. Run by `make test-board` (marker `qemu`), which
installs cppcheck."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.qemu

REPO = Path(__file__).resolve().parents[2]
DBC = REPO / "firmware_profiles" / "can-v1.dbc"
# an out-of-bounds write cppcheck reports as an error (arrayIndexOutOfBounds)
SEED = "\nint seeded_bug_reader(void);\nint seeded_bug_reader(void)\n{\n    int two[2];\n    two[2] = 1;\n" \
       "    return two[0];\n}\n"
PARTS = ["core/board.c", "plant/finger.c", "host/main.c", "inprocess/inprocess.c", "tests/test_core.c",
         "cortexm/hal_mps2.c", "avr/hal_avr.c", "arduino/valve_board/valve_board.ino"]


def run_make(board_dir: Path, build_dir: Path, target: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["make", "-s", "-C", str(board_dir), f"BUILD={build_dir}",
                           f"PYTHON={sys.executable}", f"DBC={DBC}", target],
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """build/gen (the can-v1 codec cantools generates), made once and copied into each build."""
    if shutil.which("cppcheck") is None:
        pytest.fail("cppcheck is missing: `make test-board` installs it")
    build = tmp_path_factory.mktemp("cppcheck-gen")
    result = run_make(REPO / "board", build, f"{build}/gen/can_v1.c")
    assert result.returncode == 0, result.stderr[-3000:]
    return build / "gen"


def run_cppcheck(board_dir: Path, build_dir: Path, generated: Path) -> subprocess.CompletedProcess[str]:
    shutil.copytree(generated, build_dir / "gen")  # copy2 keeps the times: make does not generate again
    return run_make(board_dir, build_dir, "cppcheck")


def test_cppcheck_is_clean_on_the_whole_board(tmp_path: Path, generated: Path) -> None:
    start = time.monotonic()
    result = run_cppcheck(REPO / "board", tmp_path / "build", generated)
    print(f"\ncppcheck on board/: exit {result.returncode} in {time.monotonic() - start:.1f} s")
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-4000:]


@pytest.mark.parametrize("part", PARTS)
def test_cppcheck_finds_a_bug_seeded_into_each_part(tmp_path: Path, part: str, generated: Path) -> None:
    board = tmp_path / "board"
    shutil.copytree(REPO / "board", board, ignore=shutil.ignore_patterns("build"))
    shutil.copytree(REPO / "csrc", tmp_path / "csrc")  # the plant's finger simulator (board/Makefile SIM_SRC)
    seeded = board / part
    seeded.write_text(seeded.read_text() + SEED)
    result = run_cppcheck(board, tmp_path / "build", generated)
    output = result.stdout + result.stderr
    assert result.returncode != 0, output[-3000:]
    assert "arrayIndexOutOfBounds" in output and Path(part).name in output, output[-3000:]
