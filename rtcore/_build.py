"""cffi build script (API mode) for the rtcore extension, named by setup.py's cffi_modules.

The cdef is read from the CDEF block of csrc/rtcore.h, the one public header, so the
Python binding and the C API cannot drift apart; API mode then compiles that same
header, so the C compiler checks every declaration against the real definitions.
"""

from __future__ import annotations

from pathlib import Path

import cffi

ROOT = Path(__file__).resolve().parent.parent
CSRC = ROOT / "csrc"
HEADER = CSRC / "rtcore.h"
SOURCES = ("rtcore_filter.c", "rtcore_model.c", "rtcore_pid.c", "rtcore_step.c", "rtcore_sim.c",
           "rtcore_gate.c", "rtcore_tick.c", "rtcore_clock.c", "rtcore_ring.c")
COMPILE_ARGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off"]
BEGIN, END = "/* BEGIN CDEF */", "/* END CDEF */"


def cdef_from_header(text: str) -> str:
    """The declarations between the CDEF markers of the public header."""
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text[start:end]


ffibuilder = cffi.FFI()
ffibuilder.cdef(cdef_from_header(HEADER.read_text()))
ffibuilder.set_source(
    "rtcore._rtcore",
    '#include "rtcore.h"\n',
    sources=[str((CSRC / name).relative_to(ROOT)) for name in SOURCES],
    include_dirs=[str(CSRC.relative_to(ROOT))],
    extra_compile_args=COMPILE_ARGS,
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
