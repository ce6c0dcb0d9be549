"""The unit of a recording column, from its name (docs/formats.md §1.3: every physical
quantity carries its unit in its name; a daemon recording suffixes it with `_<finger>`)."""

from __future__ import annotations

from collections.abc import Sequence

# name endings, longest first; a column matching none (state, mode, flags, finger) has no unit
SUFFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("_deg_per_s", "deg/s"),
    ("_kpa_per_s", "kPa/s"),
    ("_nm_per_kpa", "N*m/kPa"),
    ("_nm_per_rad", "N*m/rad"),
    ("_nms_per_rad", "N*m*s/rad"),
    ("_deg_per_mv", "deg/mV"),
    ("_kgm2", "kg*m^2"),
    ("_kpa", "kPa"),
    ("_deg", "deg"),
    ("_mv", "mV"),
    ("_hz", "Hz"),
    ("_nm", "N*m"),
    ("_n", "N"),
    ("_ms", "ms"),
    ("_us", "us"),
    ("_ns", "ns"),
    ("_s", "s"),
    ("_m", "m"),
    ("_kg", "kg"),
)
TIME_COLUMN = "t"


def quantity(name: str, fingers: Sequence[str] = ()) -> tuple[str, str | None]:
    """(the column's quantity, its finger): `angle_deg_index` -> ("angle_deg", "index")."""
    for finger in fingers:
        if name.endswith(f"_{finger}") and len(name) > len(finger) + 1:
            return name[: -len(finger) - 1], finger
    return name, None


def unit_of(name: str, fingers: Sequence[str] = ()) -> str:
    """The unit of a column ("" when it has none): `t` is in s, `angle_deg_index` in deg."""
    base, _ = quantity(name, fingers)
    if base == TIME_COLUMN:
        return "s"
    for suffix, unit in SUFFIX_UNITS:
        if base.endswith(suffix) and len(base) > len(suffix):
            return unit
    return ""
