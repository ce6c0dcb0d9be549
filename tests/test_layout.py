"""The layout stays enterable: a few top-level modules, packages by concern, small modules,
a short README."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_TOP_LEVEL_MODULES = 12
MAX_MODULE_LINES = 400
MAX_README_LINES = 150


def test_hand_service_keeps_its_modules_in_packages() -> None:
    top = sorted(p.name for p in (ROOT / "hand_service").glob("*.py"))
    assert len(top) <= MAX_TOP_LEVEL_MODULES, top


def test_every_package_is_a_regular_package() -> None:
    """A folder of modules without __init__.py is a namespace package: setuptools' find
    leaves it out of a wheel."""
    for package in ("hand_service", "rtcore"):
        for folder in (ROOT / package).rglob("*"):
            if folder.is_dir() and any(folder.glob("*.py")):
                assert (folder / "__init__.py").exists(), f"{folder.relative_to(ROOT)} has no __init__.py"


def test_no_module_is_too_long() -> None:
    long = {str(p.relative_to(ROOT)): n for package in ("hand_service", "rtcore")
            for p in (ROOT / package).rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert long == {}


def test_the_readme_is_short() -> None:
    assert len((ROOT / "README.md").read_text().splitlines()) <= MAX_README_LINES


# suites that cut across packages, or test what lies outside hand_service (board/: the C firmware)
CROSS_CUTTING_TESTS = {"board", "hil", "fuzz", "browser", "packaging"}


def test_tests_mirror_the_packages() -> None:
    """tests/<name>/ tests hand_service/<name>/ (or rtcore/): a reader finds a package's tests
    by its name."""
    packages = {p.parent.name for p in (ROOT / "hand_service").glob("*/__init__.py")} | {"rtcore"}
    folders = {p.name for p in (ROOT / "tests").iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert folders - packages - CROSS_CUTTING_TESTS == set()
