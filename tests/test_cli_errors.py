"""Bad input on the command line: one line on stderr, exit status 2, never a traceback.

Each case is checked in this process through cli.main (fast) and fails before any long
work starts: the checks come first, so a typo costs a second, not the run.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import rtcore
from hand_service import cli
from hand_service.config.profile import DEFAULT_PROFILE


def one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[str, str]:
    """Run the command; it must fail with status 2 and one line on stderr. Returns what it
    wrote on stdout, and the line (readouterr empties both, so stdout is handed back too)."""
    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert "Traceback" not in err
    assert err.count("\n") == 0, err
    assert err.startswith(f"hand-service {argv[0]}: error: "), err
    return captured.out, err


def test_run_rate_below_twice_the_filter_cutoff_names_the_key(capsys: pytest.CaptureFixture[str]) -> None:
    # 20 Hz lies in the 10-1000 Hz range, but sim.yaml filters at 25 Hz (the C core refused it)
    _, err = one_line_error(capsys, ["run", "--rate", "20", "--no-socket", "--duration", "0.1"])
    assert "--rate 20 Hz: control.filter_cutoff_hz = 25 Hz must be below half the control rate" in err
    assert f"{DEFAULT_PROFILE}:" in err  # where the cutoff is set, with its line


def test_bench_rate_is_checked_before_measuring(capsys: pytest.CaptureFixture[str]) -> None:
    out, err = one_line_error(capsys, ["bench", "--quick", "--rate", "20"])
    assert "control.filter_cutoff_hz = 25 Hz" in err
    assert "control step" not in out  # nothing was measured


@pytest.mark.parametrize("command", ["run", "bench"])
@pytest.mark.parametrize("rate", ["5", "1001", "nan"])
def test_rate_outside_the_range(capsys: pytest.CaptureFixture[str], command: str, rate: str) -> None:
    extra = "--no-socket" if command == "run" else "--quick"
    _, err = one_line_error(capsys, [command, "--rate", rate, extra])
    assert "--rate must be between 10 and 1000 Hz" in err


def test_an_rtcore_config_error_is_one_line_too(capsys: pytest.CaptureFixture[str],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """The last line of defence: a configuration only the C core refuses."""
    from hand_service.commands import simulate

    def refused(_args: object) -> int:
        raise rtcore.ConfigError("finger 0: sensor calibration must be finite with a non-zero gain")

    monkeypatch.setattr(simulate, "main", refused)
    _, err = one_line_error(capsys, ["simulate", "-o", "x.csv", "--profile", "my.yaml"])
    assert "the control core refused the configuration of my.yaml: finger 0: sensor" in err


def test_other_exceptions_are_not_swallowed(monkeypatch: pytest.MonkeyPatch) -> None:
    from hand_service.commands import simulate

    def bug(_args: object) -> int:
        raise ValueError("a bug, not a user's mistake")

    monkeypatch.setattr(simulate, "main", bug)
    with pytest.raises(ValueError, match="a bug"):
        cli.main(["simulate", "-o", "x.csv"])


def not_a_dir(tmp_path: Path) -> Path:
    """A path whose parent is a regular file: nobody, not even root, can create it."""
    (tmp_path / "file").write_text("x")
    return tmp_path / "file" / "sub"


CASES = {
    "run tcp port too high": (["run", "--no-socket", "--tcp-port", "70000", "--duration", "1"],
                              "--tcp-port must be 0 to 65535"),
    "run tcp port negative": (["run", "--no-socket", "--tcp-port", "-1", "--duration", "1"],
                              "--tcp-port must be 0 to 65535"),
    "ctl tcp port too high": (["ctl", "--tcp-port", "70000", "status"], "--tcp-port must be 1 to 65535"),
    "ctl tcp port 0": (["ctl", "--tcp-port", "0", "status"], "--tcp-port must be 1 to 65535"),
    "run duration nan": (["run", "--no-socket", "--duration", "nan"], "--duration must be a positive"),
    "run record sync zero": (["run", "--no-socket", "--record-sync-s", "0", "--duration", "1"],
                             "--record-sync-s must be a positive"),
    "bench machine with io": (["bench", "--machine", "--io"], "--machine checks the machine alone"),
    "bench machine with spin": (["bench", "--machine", "--spin-us", "10"], "it takes --seconds"),
    "bench record sync off": (["bench", "--recorder", "off", "--record-sync-s", "1"], "needs a recording"),
    "run duration negative": (["run", "--no-socket", "--duration", "-1"], "--duration must be a positive"),
    "run spin nan": (["run", "--no-socket", "--duration", "1", "--spin-us", "nan"], "--spin-us must be"),
    "run seed negative": (["run", "--no-socket", "--duration", "1", "--seed", "-1"], "--seed must be"),
    "run seed huge": (["run", "--no-socket", "--duration", "1", "--seed", str(2**64)], "--seed must be"),
    "run priority": (["run", "--no-socket", "--duration", "1", "--realtime-priority", "1000"],
                     "--realtime-priority must be 1 to 99"),
    "run socket dir": (["run", "--duration", "1", "--socket", "{bad}/api.sock"],
                       "cannot create its directory"),
    "bench seconds nan": (["bench", "--quick", "--seconds", "nan"], "--seconds must be positive"),
    "bench spin nan": (["bench", "--quick", "--spin-us", "nan"], "--spin-us between 0 and the period"),
    "bench json dir": (["bench", "--quick", "--json", "{tmp}"], "cannot write: Is a directory"),
    "bench json no dir": (["bench", "--quick", "--json", "{bad}/x.json"], "cannot write: no directory"),
    "mock seconds nan": (["mock-firmware", "--profile", "serial-v1.yaml", "--seconds", "nan"],
                         "--seconds must be a positive"),
    "mock seed": (["mock-firmware", "--profile", "serial-v1.yaml", "--seed", "-1"], "--seed must be"),
    "mock broken": (["mock-firmware", "--profile", "serial-v1.yaml", "--broken", "none"],
                    "--broken must be one of"),
    "mock port file": (["mock-firmware", "--profile", "serial-v1.yaml", "--port", "{file}"],
                       "exists and is not a terminal"),
    "mock port not a tty": (["mock-firmware", "--profile", "serial-v1.yaml", "--port", "/dev/null"],
                            "a device, but not a terminal"),
    "mock port no dir": (["mock-firmware", "--profile", "serial-v1.yaml", "--port", "{bad}/tty"],
                         "cannot play the device at"),
    "mock slcan port dir": (["mock-firmware", "--profile", "can-v1-slcan.yaml", "--port", "{tmp}"],
                            "exists and is not a terminal"),
    "simulate noise inf": (["simulate", "-o", "{tmp}/s.csv", "--noise", "inf"], "--noise must be"),
    "simulate noise huge": (["simulate", "-o", "{tmp}/s.csv", "--noise", "1e300"], "--noise must be"),
    "simulate conceal nan": (["simulate", "-o", "{tmp}/s.csv", "--conceal", "nan"], "--conceal must be"),
    "simulate duration": (["simulate", "-o", "{tmp}/s.csv", "--duration", "1e9"], "--duration must be"),
    "simulate seed": (["simulate", "-o", "{tmp}/s.csv", "--seed", "-1"], "--seed must be"),
    "simulate output": (["simulate", "-o", "{bad}/s.csv"], "cannot write: no directory"),
    "simulate truth": (["simulate", "-o", "{tmp}/s.csv", "--truth", "{tmp}"], "cannot write: Is a directory"),
    "trials seed": (["trials", "release", "--out", "{tmp}/t", "--seed", "-1"], "--seed must be"),
    "trials count": (["trials", "release", "--out", "{tmp}/t", "--count", "100000000000"],
                     "--count must be 1 to 10000"),
    "trials out": (["trials", "release", "--out", "{bad}"], "cannot create"),
    "replicate seed": (["replicate", "--quick", "--seed", "-1"], "--seed must be"),
    "replicate plots": (["replicate", "--quick", "--plots", "{bad}"], "cannot create"),
    "replicate trials": (["replicate", "--quick", "--trials", "{bad}"], "cannot create"),
    "replicate json": (["replicate", "--quick", "--json", "{tmp}"], "cannot write: Is a directory"),
    "diagnose json": (["diagnose", "{recording}", "--model", str(DEFAULT_PROFILE), "--finger", "index",
                       "--json", "{bad}/d.json"], "cannot write: no directory"),
    "diagnose still": (["diagnose", "{recording}", "--model", str(DEFAULT_PROFILE), "--finger", "index"],
                       "angle_deg is 0 deg throughout: nothing moved"),
    "diagnose report": (["diagnose", "{recording}", "--model", str(DEFAULT_PROFILE), "--finger", "index",
                         "--report", "{tmp}"], "cannot write: Is a directory"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path, case: str) -> None:
    argv, message = CASES[case]
    recording = tmp_path / "rec.csv"
    recording.write_text("t,pressure_kpa,angle_deg\n" + "".join(f"{i / 100},0,0\n" for i in range(200)))
    places = {"tmp": str(tmp_path), "bad": str(not_a_dir(tmp_path)), "file": str(tmp_path / "file"),
              "recording": str(recording)}
    out, err = one_line_error(capsys, [arg.format(**places) for arg in argv])
    assert message in err, err
    assert "wrote" not in out and "control step" not in out  # refused before any work


def test_plot_paths(tmp_path: Path) -> None:
    from hand_service.errors import UserError
    from hand_service.identification.plots import pyplot, save

    with pytest.raises(UserError, match="Format 'txt' is not supported"):
        save(pyplot().figure(), tmp_path / "figure.txt")
    with pytest.raises(UserError, match="Is a directory"):
        save(pyplot().figure(), tmp_path)
    written = save(pyplot().figure(), tmp_path / "figure")
    assert written == tmp_path / "figure.png" and written.exists()  # the file it says it wrote


def strict_json(text: str) -> object:
    """json.loads that refuses NaN and Infinity, which are not JSON."""
    def refuse(constant: str) -> None:
        raise AssertionError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_bench_json_writes_nan_as_null(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """jitter_ratio_p99 is NaN when the floor's p99 is 0; bare json.dump wrote `NaN`."""
    from hand_service.bench import tick as tickbench

    def ticks(*_args: object, **_kwargs: object) -> dict[str, object]:
        return {"rate_hz": 100.0, "ticks": 100, "tick_ns_p50": 1e5, "tick_ns_p99": 2e5,
                "jitter_us_p50": 0.0, "jitter_us_p99": 0.0, "jitter_us_max": 0.0,
                "jitter_floor_us_p50": 0.0, "jitter_floor_us_p99": 0.0, "jitter_floor_us_max": 0.0,
                "deadline_misses": 0, "deadline_misses_floor": 0, "deadline_misses_woke_late": 0,
                "cpu_percent": 1.0,
                "cpu_percent_floor": 0.1, "realtime": "off", "faults": 0, "jitter_ratio_p99": float("nan")}

    monkeypatch.setattr(tickbench, "measure_ticks", ticks)
    out = tmp_path / "bench.json"
    assert cli.main(["bench", "--quick", "--json", str(out)]) == 0
    figures = strict_json(out.read_text())
    assert figures["jitter_ratio_p99"] is None and figures["c_step_ns_p50"] > 0
    capsys.readouterr()
    assert cli.main(["bench", "--quick", "--json", "-"]) == 0  # stdout: the JSON alone
    captured = capsys.readouterr()
    assert strict_json(captured.out)["fingers"] == 5
    assert "control step" in captured.err


def test_diagnose_json_writes_inf_std_as_null(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A finger at rest (no pressure, sensor noise only) cannot tell k or B: their std is
    inf, written as null (bare json.dump wrote `Infinity`)."""
    noise_deg = np.random.default_rng(1).normal(0.0, 0.3, 500)
    noise_deg[:5] = 0.0  # at rest when the recording starts: the model stays at 0 deg
    recording = tmp_path / "still.csv"
    recording.write_text("t,pressure_kpa,angle_deg\n" + "".join(f"{i / 100},0,{a:.3f}\n"
                                                                for i, a in enumerate(noise_deg)))
    out = tmp_path / "diag.json"
    argv = ["diagnose", str(recording), "--model", str(DEFAULT_PROFILE), "--finger", "index", "--quiet"]
    assert cli.main([*argv, "--json", str(out)]) == 0
    result = strict_json(out.read_text())
    assert result["refit_std"] == {"stiffness_nm_per_rad": None, "damping_nms_per_rad": None}
    for key in ("verdict", "refit", "effects", "windows", "rmse_deg", "warnings"):  # docs/formats.md
        assert key in result
    capsys.readouterr()
    assert cli.main([*argv, "--json", "-"]) == 0
    captured = capsys.readouterr()
    assert strict_json(captured.out)["verdict"] == result["verdict"]
    assert "verdict:" in captured.err  # the summary, off stdout


def test_simulate_truth_to_stdout(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    output = tmp_path / "s.csv"
    assert cli.main(["simulate", "-o", str(output), "--duration", "2", "--truth", "-"]) == 0
    captured = capsys.readouterr()
    truth = strict_json(captured.out)
    assert truth["truth"]["finger"] == "index" and truth["seed"] == 0
    assert f"wrote {output}" in captured.err and output.exists()
