"""cffi build script (API mode) for the rtcore extension, named by setup.py's cffi_modules.

csrc/ has one public header per C unit, each with one CDEF block; the cdef is those blocks
joined in the dependency order of HEADERS (a header's block may use what the blocks before
it declare), so the Python binding and the C API cannot drift apart. The build refuses a
header with a CDEF block that HEADERS does not list, one that includes a listed header
listed after it, and an umbrella csrc/rtcore.h that does not include them all. API mode
then compiles the umbrella, so the C compiler checks every declaration against the real
definitions.

The can-v1 pack/unpack that csrc/rtcore_can.c wraps is generated here, at build time, from
firmware_profiles/can-v1.dbc by cantools' C source generator (rtcore_can_v1.[ch] in build/gen/, never
committed), so the DBC stays the one truth; cantools is a build requirement (pyproject.toml).
"""

from __future__ import annotations

import re
from pathlib import Path

import cffi
from cantools.database import load_file
from cantools.database.can.c_source import generate

ROOT = Path(__file__).resolve().parent.parent
CSRC = ROOT / "csrc"
HEADER = CSRC / "rtcore.h"  # the umbrella: includes every header of HEADERS, no CDEF block
HEADERS = tuple(CSRC / name for name in ("rtcore_step.h", "rtcore_pneumatic.h", "rtcore_exact.h",
                                         "rtcore_sim_plant.h", "rtcore_sim.h", "rtcore_clock.h",
                                         "rtcore_ring.h", "rtcore_gate.h", "rtcore_tick.h", "rtcore_can.h"))
SOURCES = ("rtcore_filter.c", "rtcore_model.c", "rtcore_pid.c", "rtcore_config.c", "rtcore_step.c",
           "rtcore_sim.c", "rtcore_sim_motion.c", "rtcore_sim_plant.c", "rtcore_sim_etdrk4.c",
           "rtcore_sim_knee.c", "rtcore_sim_kink.c", "rtcore_sim_torque.c", "rtcore_sim_step_size.c",
           "rtcore_sim_advance.c", "rtcore_sim_span.c", "rtcore_exact.c", "rtcore_sim_link.c",
           "rtcore_gate.c", "rtcore_tick.c", "rtcore_clock.c", "rtcore_ring.c", "rtcore_pneumatic.c",
           "rtcore_can.c", "rtcore_can_encode.c", "rtcore_can_tick.c")
DBC = ROOT / "firmware_profiles" / "can-v1.dbc"
GENERATED = ROOT / "build" / "gen"  # rtcore_can_v1.c and .h, from DBC (generate_can_v1)
CAN_V1 = "rtcore_can_v1"  # their names and the prefix of every symbol in them (exported: rtcore_)
# the valve board's chamber physics and pressure regulator (pneumatics.c, regulator.c), which
# csrc/rtcore_pneumatic.c includes: one source for the firmware and the simulator's pneumatic valves
BOARD_DIRS = ("board/plant", "board/core")
COMPILE_ARGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-ffp-contract=off"]
BEGIN, END = "/* BEGIN CDEF */", "/* END CDEF */"
INCLUDE = re.compile(r'^\s*#\s*include\s+"(rtcore\w*\.h)"', re.M)


def cdef_from_header(text: str) -> str:
    """The declarations between the CDEF markers of one header."""
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    return text[start:end]


def check_headers(headers: tuple[Path, ...] = HEADERS, umbrella: Path = HEADER) -> None:
    """Raise ValueError when the headers and HEADERS disagree (see the module docstring)."""
    names = [path.name for path in headers]
    with_block = {path.name for path in CSRC.glob("*.h") if BEGIN in path.read_text()}
    if with_block != set(names):
        raise ValueError(f"CDEF blocks in {sorted(with_block)}, but HEADERS lists {names}")
    for position, path in enumerate(headers):
        text = path.read_text()
        if text.count(BEGIN) != 1 or text.count(END) != 1:
            raise ValueError(f"{path.name}: needs exactly one CDEF block")
        later = [name for name in INCLUDE.findall(text) if name in names[position + 1:]]
        if later:
            raise ValueError(f"{path.name} includes {later}, listed after it in HEADERS")
    missing = set(names) - set(INCLUDE.findall(umbrella.read_text()))
    if missing:
        raise ValueError(f"{umbrella.name} does not include {sorted(missing)}")


def cdef_from_headers(headers: tuple[Path, ...] = HEADERS) -> str:
    """The CDEF blocks of the headers, joined in order: what cffi is given."""
    check_headers(headers)
    return "".join(f"\n/* {path.name} */" + cdef_from_header(path.read_text()) for path in headers)


def generate_can_v1(dbc: Path = DBC, out: Path = GENERATED, name: str = CAN_V1, **options: bool) -> Path:
    """NAME.c and .h from the DBC by cantools (rtcore's: doubles, as the Python codec decodes;
    the board's: `options` as board/Makefile gives them); rewritten only when their text
    changes, so an unchanged DBC rebuilds nothing."""
    header, source, _, _ = generate(load_file(str(dbc), database_format="dbc", strict=True), name,
                                    f"{name}.h", f"{name}.c", f"{name}_fuzzer.c", **options)
    out.mkdir(parents=True, exist_ok=True)
    for file_name, text in ((f"{name}.h", header), (f"{name}.c", source)):
        path = out / file_name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
    return out / f"{name}.c"


ffibuilder = cffi.FFI()
ffibuilder.cdef(cdef_from_headers())
ffibuilder.set_source(
    "rtcore._rtcore",
    f'#include "{HEADER.name}"\n',
    sources=[str((CSRC / name).relative_to(ROOT)) for name in SOURCES]
    + [str(generate_can_v1().relative_to(ROOT))],
    include_dirs=[str(CSRC.relative_to(ROOT)), *BOARD_DIRS, str(GENERATED.relative_to(ROOT))],
    extra_compile_args=COMPILE_ARGS,
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
