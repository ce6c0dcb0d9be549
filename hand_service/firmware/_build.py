"""cffi build script (API mode) for hand_service.firmware._board: the valve-board firmware
(board/core, its test image) with the simulated hand (board/plant) and the in-process HAL
(board/inprocess), named by setup.py's cffi_modules.

One source of truth, as rtcore/_build.py keeps it: the core's and the plant's source lists
and the test image's defines are read from board/Makefile (CORE_SRC, PLANT_SRC, HOST_DEFS),
which builds the same core for the host process (board-host) and the MCU ports; the cdef is
the CDEF block of board/inprocess/inprocess.h; the can-v1 pack/unpack is generated from the
DBC by cantools with board/Makefile's options (build/gen/can_v1.[ch], never committed).
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path
from types import ModuleType

import cffi

ROOT = Path(__file__).resolve().parents[2]
BOARD = ROOT / "board"
HEADER = BOARD / "inprocess" / "inprocess.h"
HAL_SOURCES = ("host/hal_plant.c", "host/hand_default.c", "inprocess/inprocess.c")
INCLUDE_DIRS = ("core", "plant", "host", "inprocess", "../csrc")
DBC = ROOT / "firmware_profiles" / "can-v1.dbc"
GENERATED = ROOT / "build" / "gen"  # can_v1.c and .h (rtcore's are rtcore_can_v1.*)
CAN_V1 = "can_v1"  # board/Makefile's --database-name


def makefile_variable(name: str, makefile: Path = BOARD / "Makefile") -> list[str]:
    """The words of `NAME := ...` in board/Makefile."""
    match = re.search(rf"^{name}\s*:=(.*)$", makefile.read_text(), re.M)
    if match is None:
        raise ValueError(f"{makefile}: no {name} := line")
    return match.group(1).split()


def rtcore_build() -> ModuleType:
    """rtcore/_build.py, loaded by its path (a build script runs before its package is built):
    its compile flags, CDEF markers and cantools generator serve the board's binding too."""
    spec = importlib.util.spec_from_file_location("rtcore_build", ROOT / "rtcore" / "_build.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


RTCORE = rtcore_build()


def generate_can_v1() -> Path:
    """can_v1.c and .h as board/Makefile generates them (--use-float --use-round)."""
    return RTCORE.generate_can_v1(DBC, GENERATED, CAN_V1, use_float=True, use_round=True)


def board_sources() -> list[str]:
    names = [*makefile_variable("CORE_SRC"), *makefile_variable("PLANT_SRC"), *HAL_SOURCES]
    return [str((BOARD / name).relative_to(ROOT)) for name in names]


def defines() -> list[tuple[str, str | None]]:
    """board/Makefile's HOST_DEFS (-DNAME or -DNAME=VALUE): the test image's."""
    pairs = [flag[2:].partition("=") for flag in makefile_variable("HOST_DEFS") if flag.startswith("-D")]
    return [(name, value or None) for name, _, value in pairs]


ffibuilder = cffi.FFI()
ffibuilder.cdef(RTCORE.cdef_from_header(HEADER.read_text()))
ffibuilder.set_source(
    "hand_service.firmware._board",
    f'#include "{HEADER.name}"\n',
    sources=[*board_sources(), str(generate_can_v1().relative_to(ROOT))],
    include_dirs=[*(f"board/{name}" for name in INCLUDE_DIRS), str(GENERATED.relative_to(ROOT))],
    define_macros=defines(),
    extra_compile_args=RTCORE.COMPILE_ARGS,
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
