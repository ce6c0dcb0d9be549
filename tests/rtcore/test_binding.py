"""The public headers, the cffi binding and the Python dataclasses stay in step."""

from __future__ import annotations

import dataclasses
import re
import shutil
import subprocess
import typing
from pathlib import Path

import pytest

import rtcore
from rtcore import Effects, FingerConfig, Prbm, config
from rtcore._build import BOARD_DIRS, HEADER, HEADERS, cdef_from_header, cdef_from_headers, check_headers
from rtcore._rtcore import ffi, lib
from rtcore.arrays import Inputs, Outputs, field_names
from rtcore.sim import SimFinger

ROOT = Path(__file__).resolve().parents[2]
ALL_HEADERS = "".join(path.read_text() for path in HEADERS)


def c_fields(struct: str) -> list[str]:
    return [name for name, _ in ffi.typeof(struct).fields]


def c_tree(ctype: object) -> dict[str, object]:
    """A struct's member names, each with its own tree if it is a struct (else None)."""
    return {name: c_tree(f.type) if f.type.kind == "struct" else None
            for name, f in ctype.fields}  # type: ignore[attr-defined]


def py_tree(cls: type) -> dict[str, object]:
    """A dataclass's field names, each with its own tree if it is a dataclass (else None)."""
    hints = typing.get_type_hints(cls)
    return {f.name: py_tree(hints[f.name]) if dataclasses.is_dataclass(hints[f.name]) else None
            for f in dataclasses.fields(cls)}


@pytest.mark.parametrize(("struct", "cls"), [("rtcore_inputs", Inputs), ("rtcore_outputs", Outputs),
                                              ("rtcore_effects", Effects), ("rtcore_prbm", Prbm)])
def test_dataclass_fields_equal_c_fields(struct: str, cls: type) -> None:
    assert field_names(cls) == c_fields(struct)


@pytest.mark.parametrize(("struct", "cls"), [("rtcore_finger_config", FingerConfig),
                                              ("rtcore_sim_finger", SimFinger)])
def test_finger_fields_equal_c_fields_at_every_level(struct: str, cls: type) -> None:
    """The same names at every level (in any order: Python puts prbm, without a default, first),
    and a nested dataclass where the C struct nests one."""
    assert py_tree(cls) == c_tree(ffi.typeof(struct))


def test_controller_and_simulator_share_one_prbm() -> None:
    """One PRBM declaration per language: both finger structs hold rtcore_prbm, both
    dataclasses Prbm."""
    for struct in ("rtcore_finger_config", "rtcore_sim_finger"):
        assert dict(ffi.typeof(struct).fields)["prbm"].type is ffi.typeof("rtcore_prbm")
    for cls in (FingerConfig, SimFinger):
        assert typing.get_type_hints(cls)["prbm"] is Prbm


def test_python_constants_equal_header_constants() -> None:
    names = re.findall(r"#define (RTCORE_(?:MODE|FF|FLAG)_\w+)", ALL_HEADERS)
    assert len(names) > 10
    for name in names:
        python_name = name.removeprefix("RTCORE_")
        assert getattr(config, python_name) == getattr(lib, name), name
    assert lib.RTCORE_MAX_FINGERS == config.MAX_FINGERS


def test_every_header_function_is_bound() -> None:
    declared = set(re.findall(r"\b(rtcore_\w+)\s*\(", cdef_from_headers()))
    assert declared, "no functions found in the CDEF block"
    for name in declared:
        assert hasattr(lib, name), name


def test_extension_exports_only_prefixed_symbols() -> None:
    """glibc has a legacy step(): every symbol we export must carry the rtcore_ prefix."""
    library = Path(rtcore._rtcore.__file__)
    listing = subprocess.run(["nm", "-D", "--defined-only", str(library)], capture_output=True,
                             text=True, check=True).stdout
    exported = [line.split()[-1] for line in listing.splitlines() if line.split()[1] in "TDBR"]
    ours = [name for name in exported if not name.startswith(("PyInit_", "_init", "_fini"))]
    assert ours, "nm listed nothing"
    assert all(name.startswith("rtcore_") for name in ours), [n for n in ours if not n.startswith("rtcore_")]


@pytest.mark.parametrize("header", HEADERS, ids=lambda path: path.name)
def test_header_block_has_only_what_cffi_parses(header: Path) -> None:
    block = re.sub(r"/\*.*?\*/", "", cdef_from_header(header.read_text()), flags=re.S)
    assert "#include" not in block and "#if" not in block and "static" not in block


def test_build_refuses_headers_out_of_step() -> None:
    """A CDEF block the build does not list, or listed before what it includes, fails the build."""
    check_headers()
    with pytest.raises(ValueError, match="HEADERS lists"):
        check_headers(HEADERS[:-1])
    with pytest.raises(ValueError, match="listed after it"):
        check_headers(HEADERS[::-1])


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
@pytest.mark.parametrize("header", [HEADER, *HEADERS, *(HEADER.with_name(f"rtcore_{name}internal.h")
                                                        for name in ("", "sim_"))],
                         ids=lambda path: path.name)
def test_each_header_compiles_on_its_own(header: Path) -> None:
    """Every header includes what it uses."""
    built = subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-fsyntax-only",
                            *(f"-I{ROOT / name}" for name in BOARD_DIRS), "-x", "c", str(header)],
                           capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
