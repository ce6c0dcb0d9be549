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

import re
from pathlib import Path

import cffi
from cantools.database import load_file
from cantools.database.can.c_source import generate

ROOT = Path(__file__).resolve().parents[2]
BOARD = ROOT / "board"
HEADER = BOARD / "inprocess" / "inprocess.h"
HAL_SOURCES = ("host/hal_plant.c", "host/hand_default.c", "inprocess/inprocess.c")
INCLUDE_DIRS = ("core", "plant", "host", "inprocess", "../csrc")
DBC = ROOT / "firmware_profiles" / "can-v1.dbc"
GENERATED = ROOT / "build" / "gen"  # can_v1.c and .h (rtcore's are rtcore_can_v1.*)
CAN_V1 = "can_v1"  # board/Makefile's --database-name
COMPILE_ARGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off"]
BEGIN, END = "/* BEGIN CDEF */", "/* END CDEF */"


def makefile_variable(name: str, makefile: Path = BOARD / "Makefile") -> list[str]:
    """The words of `NAME := ...` in board/Makefile."""
    match = re.search(rf"^{name}\s*:=(.*)$", makefile.read_text(), re.M)
    if match is None:
        raise ValueError(f"{makefile}: no {name} := line")
    return match.group(1).split()


def cdef(header: Path = HEADER) -> str:
    text = header.read_text()
    return text[text.index(BEGIN) + len(BEGIN):text.index(END)]


def generate_can_v1(dbc: Path = DBC, out: Path = GENERATED) -> Path:
    """can_v1.c and .h as board/Makefile generates them (--use-float --use-round); rewritten
    only when their text changes."""
    header, source, _, _ = generate(load_file(str(dbc), database_format="dbc", strict=True), CAN_V1,
                                    f"{CAN_V1}.h", f"{CAN_V1}.c", f"{CAN_V1}_fuzzer.c", use_float=True,
                                    use_round=True)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in ((f"{CAN_V1}.h", header), (f"{CAN_V1}.c", source)):
        path = out / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
    return out / f"{CAN_V1}.c"


def board_sources() -> list[str]:
    names = [*makefile_variable("CORE_SRC"), *makefile_variable("PLANT_SRC"), *HAL_SOURCES]
    return [str((BOARD / name).relative_to(ROOT)) for name in names]


def defines() -> list[tuple[str, str | None]]:
    """board/Makefile's HOST_DEFS (-DNAME or -DNAME=VALUE): the test image's."""
    pairs = [flag[2:].partition("=") for flag in makefile_variable("HOST_DEFS") if flag.startswith("-D")]
    return [(name, value or None) for name, _, value in pairs]


ffibuilder = cffi.FFI()
ffibuilder.cdef(cdef())
ffibuilder.set_source(
    "hand_service.firmware._board",
    f'#include "{HEADER.name}"\n',
    sources=[*board_sources(), str(generate_can_v1().relative_to(ROOT))],
    include_dirs=[*(f"board/{name}" for name in INCLUDE_DIRS), str(GENERATED.relative_to(ROOT))],
    define_macros=defines(),
    extra_compile_args=COMPILE_ARGS,
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
