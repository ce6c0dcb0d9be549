"""Progress of the long commands: a tqdm bar on a terminal; plain lines, no `\\r`, when
stderr is a file; nothing with --quiet; and a `done in` that is the process's wall time."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.commands.progress import Progress, wall_time_s


def run(args: list[str], tmp_path: Path, name: str) -> tuple[str, str, float]:
    """`hand-service ARGS` with stderr to a file (as a log or CI has it): (stdout, stderr,
    the wall time the test saw)."""
    err_path = tmp_path / f"{name}.err"
    started = time.monotonic()
    with open(err_path, "w") as err:
        proc = subprocess.run([sys.executable, "-m", "hand_service.cli", *args], stdout=subprocess.PIPE,
                              stderr=err, text=True, timeout=300, cwd=tmp_path,
                              env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])})
    seen_s = time.monotonic() - started
    stderr = err_path.read_bytes().decode()
    assert proc.returncode == 0, stderr
    return proc.stdout, stderr, seen_s


def progress_lines(stderr: str, label: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith(f"{label}: ")]


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    tmp = tmp_path_factory.mktemp("progress")
    rec, nominal = tmp / "rec.csv", tmp / "nominal.yaml"
    assert main(["simulate", "-o", str(rec), "--duration", "10", "--nominal-model", str(nominal)]) == 0
    return rec, nominal


def test_diagnose_to_a_file_writes_lines_not_carriage_returns(recording: tuple[Path, Path], tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    rec, nominal = recording
    _, stderr, seen_s = run(["diagnose", str(rec), "--model", str(nominal)], tmp_path, "diagnose")
    assert "\r" not in stderr
    lines = progress_lines(stderr, "diagnose")
    assert lines[0].startswith("diagnose: [") and "simulating the nominal model" in lines[0]
    assert lines[-1].startswith("diagnose: done in ")
    assert 0.0 < float(lines[-1].split()[-2]) <= seen_s + 0.1
    assert main(["diagnose", str(rec), "--model", str(nominal), "--quiet"]) == 0
    quiet = capsys.readouterr()
    assert quiet.err == "" and quiet.out.startswith("verdict: ")


def test_trials_count_in_lines_and_quiet_silences_them(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    fingers = ["--finger", "thumb", "--finger", "ring"]
    out, stderr, _ = run(["trials", "pairs", "--count", "2", "--out", "t", *fingers], tmp_path, "trials")
    assert "\r" not in stderr
    lines = progress_lines(stderr, "trials")
    assert lines[0].startswith("trials: [") and " 0/4 simulating thumb's pairs trials" in lines[0]
    assert lines[-1].startswith("trials: done in ")
    assert "ring: 2 pairs recording(s) in t" in out  # the results stay on stdout
    assert main(["trials", "pairs", "--count", "2", "--out", str(tmp_path / "q"), "--quiet", *fingers]) == 0
    quiet = capsys.readouterr()
    assert quiet.err == "" and "ring: 2 pairs recording(s) in" in quiet.out


def test_replicate_says_its_wall_time(tmp_path: Path) -> None:
    """`done in N s`: the process's whole wall time (start-up, imports, simulations,
    figures), not the simulations' alone: at least 60 % of what the test measured from
    outside, and no more than it. The same run is the command's end-to-end test: its
    tables on stdout, its JSON and its figures."""
    from tests.replicate.test_replicate import check_json

    out, stderr, seen_s = run(["replicate", "--quick", "--json", "r.json", "--plots", "plots"], tmp_path,
                              "replicate")
    assert "\r" not in stderr and "| finger |" in out and "### Table 2" in out
    check_json(json.loads((tmp_path / "r.json").read_text()))
    assert {p.name for p in (tmp_path / "plots").iterdir()} >= {"table1_ldm.png", "table2_tracking.png",
                                                                "force.png", "identify_index.png"}
    done = progress_lines(stderr, "replicate")[-1]
    assert done.startswith("replicate: done in ")
    said_s = float(done.split()[-2])
    assert 0.6 * seen_s <= said_s <= seen_s + 0.1, (said_s, seen_s)


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_terminal_gets_a_tqdm_bar_and_a_file_periodic_lines() -> None:
    tty = Terminal()
    with Progress("work", total=4, stream=tty) as bar:
        for k in range(4):
            time.sleep(0.25)  # past tqdm's minimum interval between redraws
            bar.advance(message=f"step {k}")
    drawn = tty.getvalue()
    assert "\r" in drawn and "work:" in drawn and "step" in drawn  # redrawn in place
    log = io.StringIO()
    lines = Progress("work", total=400, stream=log, every_s=0.05)
    for k in range(400):
        lines.advance(message=f"step {k}")
        time.sleep(0.001)
    text = log.getvalue()
    assert "\r" not in text
    assert 2 <= text.count("\n") < 100  # periodic: not one a step
    assert text.startswith("work: [") and " 1/400 step 0\n" in text
    quiet = io.StringIO()
    silent = Progress("work", total=3, stream=quiet, quiet=True)
    silent.advance(message="x")
    silent.say("y")
    silent.done()
    assert quiet.getvalue() == "" and silent.count == 1


def test_wall_time_counts_from_the_process_start() -> None:
    """This test process started before the test ran: its age exceeds the time since any
    module was imported now, and it grows with the clock."""
    first = wall_time_s()
    time.sleep(0.05)
    assert wall_time_s() >= first + 0.03
    assert first > 0.1  # pytest itself took longer than that to get here
