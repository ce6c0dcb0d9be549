"""The public header, the cffi binding and the Python dataclasses stay in step."""

from __future__ import annotations

import dataclasses
import re
import subprocess
from pathlib import Path

import pytest

import rtcore
from rtcore import Effects, FingerConfig, config
from rtcore._build import HEADER, cdef_from_header
from rtcore._rtcore import ffi, lib
from rtcore.arrays import Inputs, Outputs, field_names

ROOT = Path(__file__).resolve().parents[2]


def c_fields(struct: str) -> list[str]:
    return [name for name, _ in ffi.typeof(struct).fields]


@pytest.mark.parametrize(("struct", "cls"), [("rtcore_inputs", Inputs), ("rtcore_outputs", Outputs),
                                              ("rtcore_effects", Effects)])
def test_dataclass_fields_equal_c_fields(struct: str, cls: type) -> None:
    assert field_names(cls) == c_fields(struct)


def test_finger_config_fields_equal_c_fields() -> None:
    ours = sorted(f.name for f in dataclasses.fields(FingerConfig))
    assert ours == sorted(c_fields("rtcore_finger_config"))


def test_python_constants_equal_header_constants() -> None:
    names = re.findall(r"#define (RTCORE_(?:MODE|FF|FLAG)_\w+)", HEADER.read_text())
    assert len(names) > 10
    for name in names:
        python_name = name.removeprefix("RTCORE_")
        assert getattr(config, python_name) == getattr(lib, name), name
    assert lib.RTCORE_MAX_FINGERS == config.MAX_FINGERS


def test_every_header_function_is_bound() -> None:
    declared = set(re.findall(r"\b(rtcore_\w+)\s*\(", cdef_from_header(HEADER.read_text())))
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


def test_header_block_has_only_what_cffi_parses() -> None:
    block = re.sub(r"/\*.*?\*/", "", cdef_from_header(HEADER.read_text()), flags=re.S)
    assert "#include" not in block and "#if" not in block and "static" not in block
