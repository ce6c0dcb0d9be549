"""`hand-service identify` end to end: docs/formats.md's JSON keys, --plot, --write-model."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.config.profile import Profile, load_model

REQUIRED = {"stiffness_nm_per_rad", "damping_nms_per_rad", "damping_ratio", "natural_freq_hz",
            "damped_freq_hz",
            "log_decrement", "stiffness_std_nm_per_rad", "damping_std_nms_per_rad", "trials"}


@pytest.mark.parametrize("method", ["fit", "two-peak"])
def test_identify_writes_json_plot_and_model(method: str, profile: Profile,
                                             release_files: dict[str, list[Path]],
                                             tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(p) for p in release_files["index"][:4]]
    out, plot, model_out = tmp_path / "index.json", tmp_path / "index.png", tmp_path / "index.yaml"
    assert main(["identify", *files, "--model", str(profile.path), "--finger", "index", "--method", method,
                 "--json", str(out), "--plot", str(plot), "--write-model", str(model_out)]) == 0
    data = json.loads(out.read_text())
    assert set(data) >= REQUIRED
    assert len(data["trials"]) == 4
    for trial in data["trials"]:
        assert {"file", "stiffness_nm_per_rad", "damping_nms_per_rad"} <= set(trial)
    assert data["method"] == method
    assert plot.stat().st_size > 10_000
    table = capsys.readouterr().out
    assert "| **mean ± std** |" in table and "index_00.csv" in table
    written = load_model(model_out)
    truth = profile.finger("index").model
    assert written.stiffness_nm_per_rad == pytest.approx(data["stiffness_nm_per_rad"], rel=1e-12)
    assert written.damping_nms_per_rad == pytest.approx(data["damping_nms_per_rad"], rel=1e-12)
    assert written.inertia_kgm2 == pytest.approx(truth.inertia_kgm2, rel=1e-12)  # A held
    assert written.pressure_gain_nm_per_kpa == truth.pressure_gain_nm_per_kpa
    assert written.effects == truth.effects


def test_json_to_stdout_keeps_the_table_off_it(profile: Profile,
                                               release_files: dict[str, list[Path]]) -> None:
    result = subprocess.run([sys.executable, "-m", "hand_service.cli", "identify",
                             str(release_files["ring"][0]),
                             "--model", str(profile.path), "--finger", "ring", "--json", "-"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert set(json.loads(result.stdout)) >= REQUIRED
    assert "mean ± std" in result.stderr


def test_bad_input_is_one_line_and_status_2(profile: Profile, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    flat = tmp_path / "flat.csv"
    flat.write_text("t,pressure_kpa,angle_deg\n" + "".join(f"{k / 100},0,0.0\n" for k in range(200)))
    cases = {"no release found": ["identify", str(flat), "--model", str(profile.path), "--finger", "index"],
             "pick one with --finger": ["identify", str(flat), "--model", str(profile.path)],
             "cannot read": ["identify", str(tmp_path / "missing.csv"), "--model", str(profile.path),
                             "--finger", "index"]}
    for message, args in cases.items():
        if message == "cannot read":  # as a user runs it: the exit status and stderr a shell sees
            result = subprocess.run([sys.executable, "-m", "hand_service.cli", *args], capture_output=True,
                                    text=True, timeout=120)
            code, stderr = result.returncode, result.stderr
        else:  # in this process: an exception would fail the test as a traceback would
            capsys.readouterr()
            code = main(args)
            stderr = capsys.readouterr().err
        assert code == 2, stderr
        assert stderr.strip().count("\n") == 0 and "Traceback" not in stderr
        assert message in stderr
