"""`hand-service simulate` and `hand-service diagnose` end to end, and their bad inputs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.model import save_model
from hand_service.config.profile import load_model, load_profile
from hand_service.recording import read_recording, write_recording

REQUIRED_KEYS = {"verdict", "refit", "effects", "windows", "rmse_deg", "warnings"}
VERDICTS = {"consistent", "parameters_only", "missing_physics", "unexplained", "insufficient_excitation"}


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hand_service.cli", *args], capture_output=True, text=True,
                          timeout=300)


@pytest.fixture(scope="module")
def concealed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("concealed")
    assert main(["simulate", "--effect", "gravity", "--conceal", "0.7", "--seed", "5", "--duration", "20",
                 "-o", str(folder / "g.csv"), "--nominal-model", str(folder / "nominal.yaml"),
                 "--truth", str(folder / "truth.json")]) == 0
    return folder


def test_simulate_writes_recording_nominal_model_and_truth(concealed: Path) -> None:
    recording = read_recording(concealed / "g.csv")
    assert recording.sample_rate_hz == pytest.approx(100.0)
    assert recording.metadata["excitation"] == "steps"
    truth = json.loads((concealed / "truth.json").read_text())
    assert 0.67 < truth["concealment_residual_over_noise"] < 0.73
    nominal = load_model(concealed / "nominal.yaml")
    assert "gravity" not in nominal.effects  # hidden from the model
    assert set(nominal.effects) == {"valve_lag", "dead_time"}  # the profile's known effects stay
    for key in ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa"):
        assert abs(getattr(nominal, key) / truth["truth"][key] - 1.0) <= 0.1


def test_diagnose_json_report_and_written_model(concealed: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = concealed / "d.json"
    code = main(["diagnose", str(concealed / "g.csv"), "--model", str(concealed / "nominal.yaml"), "--json",
                 str(out), "--report", str(concealed / "d.html"), "--write-model",
                 str(concealed / "fixed.yaml"), "--quiet"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "verdict: missing_physics" in printed
    result = json.loads(out.read_text())
    assert set(result) >= REQUIRED_KEYS
    assert result["verdict"] in VERDICTS
    assert set(result["refit"]) == {"inertia_kgm2", "damping_nms_per_rad", "stiffness_nm_per_rad",
                                    "pressure_gain_nm_per_kpa"}
    nominal = load_model(concealed / "nominal.yaml")
    assert result["refit"]["inertia_kgm2"] == nominal.inertia_kgm2
    assert set(result["rmse_deg"]) == {"nominal", "refit", "augmented"}
    assert result["effects"][0]["name"] == "gravity"
    assert set(result["effects"][0]) >= {"name", "params", "evidence"}
    assert "torque_nm" in result["effects"][0]["params"]
    assert all(len(w) == 2 and w[0] < w[1] for w in result["windows"])
    html = (concealed / "d.html").read_text()
    assert html.count("data:image/png;base64,") >= 3 and "gravity" in html
    fixed = load_model(concealed / "fixed.yaml")
    assert fixed.effects["gravity"]["torque_nm"] == pytest.approx(result["effects"][0]["params"]["torque_nm"])
    assert fixed.effects["valve_lag"] == nominal.effects["valve_lag"]
    assert fixed.stiffness_nm_per_rad == pytest.approx(result["refit"]["stiffness_nm_per_rad"])


def small_recording(path: Path, n: int = 300, rate_hz: float = 100.0, **changes: object) -> Path:
    t = np.arange(n) / rate_hz
    columns = {"t": t, "pressure_kpa": np.where(t > 1.0, 50.0, 0.0), "angle_deg": np.zeros(n)}
    columns.update(changes)  # type: ignore[arg-type]
    write_recording(path, columns, {"finger": "index"})
    return path


MODEL = "firmware_profiles/sim.yaml"
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("case", "expected"), [
    ("missing_column", "missing required column 'angle_deg'"),
    ("nan", "where a finite number is required"),
    ("too_short", "at least 1 s is needed"),
    ("gap", "samples are missing"),
    ("off_grid", "not on one rate"),
    ("model_without_keys", "has no 'stiffness_nm_per_rad'"),
    ("unknown_effect", "unknown effect"),
])
def test_bad_inputs_give_one_clear_line(case: str, expected: str, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    """In this process (an exception would fail the test as a traceback would), but for one
    case run as a user runs it, in its own process: the exit status and stderr as a shell
    sees them."""
    model = str(tmp_path / "index.yaml")
    save_model(load_profile(ROOT / MODEL).finger("index").model, model)
    path = tmp_path / "r.csv"
    if case == "missing_column":
        write_recording(path, {"t": np.arange(300) / 100.0, "pressure_kpa": np.zeros(300)})
    elif case == "nan":
        angle = np.zeros(300)
        angle[40] = np.nan
        small_recording(path, angle_deg=angle)
    elif case == "too_short":
        small_recording(path, n=50)
    elif case == "gap":  # 50 of 350 samples missing: too many
        t = np.arange(300) / 100.0
        t[150:] += 0.5
        small_recording(path, t=t)
    elif case == "off_grid":  # a step of 2.5 periods: no whole number of them
        t = np.arange(300) / 100.0
        t[150:] += 0.015
        small_recording(path, t=t)
    elif case == "model_without_keys":
        small_recording(path)
        model = str(tmp_path / "m.yaml")
        Path(model).write_text("inertia_kgm2: 1.6e-4\ndamping_nms_per_rad: 0.003\n")
    elif case == "unknown_effect":
        capsys.readouterr()
        assert main(["simulate", "--effect", "magnetism", "-o", str(path)]) == 2
        assert expected in capsys.readouterr().err
        return
    if case == "nan":
        result = run_cli("diagnose", str(path), "--model", model)
        code, stderr = result.returncode, result.stderr
    else:
        capsys.readouterr()
        code = main(["diagnose", str(path), "--model", model])
        stderr = capsys.readouterr().err
    assert code == 2, stderr
    assert "Traceback" not in stderr
    assert stderr.strip().count("\n") == 0
    assert expected in stderr


def test_daemon_recording_with_a_profile_and_finger(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A multi-finger recording (suffixed columns) and the profile as the model."""
    from hand_service.diagnose.concealed.generator import generate

    model = load_profile(ROOT / MODEL).finger("middle").model
    c = generate(model, {"gravity": None}, "steps", duration_s=20.0, seed=8, perturbation=0.0)
    other = np.zeros_like(c.t_s)
    path = tmp_path / "daemon.csv"
    write_recording(path, {"t": c.t_s, "pressure_kpa_index": other, "angle_deg_index": other,
                           "pressure_kpa_middle": c.pressure_kpa, "angle_deg_middle": c.angle_deg,
                           "mode_middle": ["position"] * c.t_s.size})
    assert main(["diagnose", str(path), "--model", str(ROOT / MODEL), "--finger", "middle", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "verdict: missing_physics" in out and "1. gravity" in out


def test_no_model_written_when_the_excitation_is_insufficient(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    csv, nominal, written = tmp_path / "sine.csv", tmp_path / "n.yaml", tmp_path / "out.yaml"
    # a sine of positive pressure never bends the finger backwards
    assert main(["simulate", "--excitation", "sine", "--effect", "asymmetric_stiffness=1.5",
                 "--duration", "20", "-o", str(csv), "--nominal-model", str(nominal)]) == 0
    assert main(["diagnose", str(csv), "--model", str(nominal), "--write-model", str(written),
                 "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "verdict: insufficient_excitation" in out and "not writing" in out
    assert not written.exists()
