"""The README's "Your first hour" as a newcomer walks it: every command of the section, taken
from the README itself, in its order, in a fresh directory outside the checkout
(`make test-firsthour`, marker `firsthour`; run by .ci/run, not by make test: it runs
`replicate` twice).

What the README leaves to the reader is done as a reader would:
- commands run from .venv/bin on PATH (the section says they are there);
- `make run` is what its target runs, `hand-service run --demo` (there is no Makefile here);
- a path into the checkout (`firmware_profiles/sim.yaml`, `docs/examples/wave.csv`) is
  copied into the fresh directory at the same relative place, as a clone would hold it;
- a trial kind named without its command (`sweep`, `valve`, `pairs`) is run as the release
  trials before it are, with its own kind;
- "from another shell": the `ctl` commands run while `hand-service run` does; Ctrl-C is a
  SIGINT once the loaded trajectory has played; `run --view`/`--foxglove` and the scripts
  are alternatives with their own tests (tests/browser, tests/daemon).
Each command must exit 0 with no traceback and no unit-slip warning, no new file may appear
in the checkout and none of its profiles may change.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.service.process import wait_for

pytestmark = pytest.mark.firsthour

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TRIAL_KINDS = ("sweep", "valve", "pairs")
COMMAND_TIMEOUT_S = 1800.0


def first_hour_commands(readme: str) -> list[str]:
    """The section's commands, in order: every backticked span that is one."""
    section = readme.split("## Your first hour", 1)[1].split("\n## ", 1)[0]
    commands = []
    release = None
    for span in re.findall(r"`([^`]+)`", section):
        span = " ".join(span.split())
        if span.startswith("hand-service trials release"):
            release = span
        if span in TRIAL_KINDS:
            assert release is not None, f"`{span}` comes before the release trials it is like"
            span = re.sub(r"trials release( --count \d+)?", f"trials {span}", release)
        elif span.startswith("ctl "):
            span = "hand-service " + span
        elif span == "make run" or span.startswith(("hand-service ", "cp ", "REPO=")):
            pass
        else:
            continue  # a file name, a flag, a key, an alternative (`run --view ...`)
        commands.append(span)
    return commands


def _checkout_paths(command: str) -> list[str]:
    return [w for w in shlex.split(command) if w.startswith(("firmware_profiles/", "docs/"))]


def _run(command: str, cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    """The command as a shell runs it (a glob such as trials/index_release_*.csv expands)."""
    done = subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=COMMAND_TIMEOUT_S)
    shown = f"$ {command}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    assert done.returncode == 0, shown
    assert "Traceback" not in done.stderr and "for a finger of 1–30 cm" not in done.stderr, shown
    return done


def _git_status() -> str:
    return subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                          capture_output=True, text=True, check=True).stdout


def test_the_first_hour_as_written(tmp_path: Path) -> None:
    home = tmp_path / "home"  # the README's ~/hand-lab, in a home of the test's own
    home.mkdir()
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}", "HOME": str(home),
           "HAND_SERVICE_SOCKET": str(tmp_path / "api.sock"), "XDG_DATA_HOME": str(tmp_path / "xdg"),
           "MPLBACKEND": "Agg", "REPO": str(ROOT)}  # REPO: the shell variable the setup line sets
    commands = first_hour_commands(README.read_text())
    assert len(commands) >= 15 and commands[0].startswith("REPO=$PWD;"), commands
    _run(commands.pop(0), ROOT, env)  # in the checkout, as written: it makes ~/hand-lab
    work = home / "hand-lab"
    assert (work / "my-hand.yaml").exists() and ROOT not in work.parents
    before = _git_status()
    started = time.monotonic()
    daemon: subprocess.Popen[str] | None = None
    loaded: Path | None = None
    try:
        for command in commands:
            for path in _checkout_paths(command):
                if not (work / path).exists() and (ROOT / path).exists():
                    (work / path).parent.mkdir(parents=True, exist_ok=True)
                    shutil.copyfile(ROOT / path, work / path)
            if command == "make run":
                command = "hand-service run --demo"
            argv = shlex.split(command)
            if daemon is not None and argv[0] == "hand-service" and argv[1] != "ctl":
                _interrupt(daemon, work, env)  # Ctrl-C before the next step (a cp is in the other shell)
                daemon = None
            if argv[:2] == ["hand-service", "run"] and "--demo" not in argv:
                daemon = _start(argv, work, env)
                continue
            try:
                _run(command, work, env)
            except AssertionError as failed:
                if daemon is None:
                    raise
                log = (work.parent / "run.log").read_text()[-3000:]
                raise AssertionError(f"{failed}\nthe daemon's log (run.log):\n{log}") from None
            if argv[1:3] == ["ctl", "load"]:
                loaded = work / argv[3]
            if argv[1:3] == ["ctl", "start"] and loaded is not None:  # it plays out, then the next request
                time.sleep(_duration_s(loaded) + 0.5)
        if daemon is not None:
            _interrupt(daemon, work, env)
            daemon = None
    finally:
        if daemon is not None and daemon.poll() is None:
            daemon.kill()
            daemon.wait()
    print(f"\nfirst hour: {len(commands)} commands in {time.monotonic() - started:.0f} s")
    for made in ("my-hand.yaml", "index.yaml", "run.csv", "diag.html", "f.csv", "nominal.yaml", "plots"):
        assert (work / made).exists(), made
    assert len(list((work / "trials").glob("index_*.csv"))) >= 13  # 10 releases, a sweep, steps, pairs
    landed = [line for line in _git_status().splitlines() if line not in before.splitlines()
              and (line.startswith("??") or "firmware_profiles/" in line)]
    assert landed == [], landed  # no output landed in the checkout, no profile there changed


def _start(argv: list[str], cwd: Path, env: dict[str, str]) -> subprocess.Popen[str]:
    log = open(cwd.parent / "run.log", "w")  # noqa: SIM115 - closed with the process
    daemon = subprocess.Popen(argv, cwd=cwd, env=env, stdout=log, stderr=subprocess.STDOUT, text=True)
    wait_for(lambda: _status(cwd, env) is not None or daemon.poll() is not None, 60.0, "the daemon")
    assert daemon.poll() is None, (cwd.parent / "run.log").read_text()
    wait_for(lambda: "DISARMED" in (_status(cwd, env) or ""), 60.0, "the handshake")
    return daemon


def _status(cwd: Path, env: dict[str, str]) -> str | None:
    done = subprocess.run(["hand-service", "ctl", "status"], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=60)
    return done.stdout if done.returncode == 0 else None


def _duration_s(trajectory: Path) -> float:
    """The last `t` of a trajectory CSV."""
    rows = [line for line in trajectory.read_text().splitlines() if line and not line.startswith("#")]
    return float(rows[-1].split(",")[0])


def _interrupt(daemon: subprocess.Popen[str], cwd: Path, env: dict[str, str]) -> None:
    daemon.send_signal(signal.SIGINT)
    code = daemon.wait(60)
    log = (cwd.parent / "run.log").read_text()
    assert code == 0 and "Traceback" not in log, log[-3000:]
