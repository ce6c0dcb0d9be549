"""One battery case on disk: the recording a lab would have (docs/formats.md §1), the lab's
nominal model, and the truth beside them (`<case>.truth.json`), for diagnose to read."""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from tests.diagnose.truth.cases import Case


def write_recording(case: Case, path: Path) -> None:
    """The project's recording CSV (docs/formats.md §1), one finger."""
    rate = case.plan.rate_hz
    t = np.arange(case.plan.n) / rate
    lines = [
        "# finger: index",
        f"# sample_rate_hz: {rate:g}",
        "# source: independent truth (tests/diagnose/truth)",
        f"# case: {case.spec.id}",
        f"# excitation: {case.plan.kind}",
        "t,pressure_kpa,angle_deg",
    ]
    body = np.column_stack([t, case.trajectory.command_kpa, case.measured_deg])
    lines += [f"{a:.6f},{b:.5f},{c:.5f}" for a, b, c in body]
    path.write_text("\n".join(lines) + "\n")


def read_rows(path: Path) -> tuple[list[str], list[list[str]]]:
    """A recording's lines up to its column header (comments and header), and its data rows
    split at the commas: for a test that rewrites a recording (rows skipped, cut, shifted)."""
    lines = path.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("t,"))
    return lines[: header + 1], [line.split(",") for line in lines[header + 1:]]


def write_rows(path: Path, head: list[str], rows: list[list[str]]) -> Path:
    """The lines of read_rows written back, each row joined at commas."""
    path.write_text("\n".join([*head, *(",".join(row) for row in rows)]) + "\n")
    return path


def write_model(case: Case, path: Path) -> None:
    m = case.nominal
    text = (
        f"# the lab's nominal model of case {case.spec.id}: k, B, N off by up to 10 %\n"
        f"finger: index\ninertia_kgm2: {float(m.inertia_kgm2)!r}\n"
        f"damping_nms_per_rad: {float(m.damping_nms_per_rad)!r}\n"
        f"stiffness_nm_per_rad: {float(m.stiffness_nm_per_rad)!r}\n"
        f"pressure_gain_nm_per_kpa: {float(m.gain_nm_per_kpa)!r}\n"
    )
    if case.nominal_effects:
        text += "effects:\n"
        for name, params in case.nominal_effects.items():
            inner = ", ".join(f"{p}: {float(v)!r}" for p, v in params.items())
            text += f"  {name}: {{{inner}}}\n"
    path.write_text(text)


def write(case: Case, folder: Path) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    rec, model = folder / f"{case.spec.id}.csv", folder / f"{case.spec.id}.yaml"
    write_recording(case, rec)
    write_model(case, model)
    (folder / f"{case.spec.id}.truth.json").write_text(
        json.dumps(
            {
                **case.summary(),
                "truth": {
                    k: (v if not isinstance(v, float) or math.isfinite(v) else None)
                    for k, v in asdict(case.truth).items()
                    if k != "family"
                },
                "family_params": asdict(case.truth.family),
            },
            indent=1,
        )
    )
    return rec, model
