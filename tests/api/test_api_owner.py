"""Only the owner commands the hand (docs/api.md, "Who may connect"): the daemon as a
process, run as root here. Another user (a child that drops to nobody, uid 65534) can
reach neither the Unix socket (mode 0600; and were it opened to all, SO_PEERCRED refuses
the peer) nor the TCP port (the token file beside the socket is 0600: without the token,
or with a wrong one, the first request is refused and the connection closed). Paths in
requests stay inside the recording directory, and a start that is refused leaves nothing
behind. SIGUSR1 vents the hand without any socket."""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hand_service.api.client import ApiError, HandClient
from hand_service.cli import main
from hand_service.recording import read_recording
from tests.service.process import DaemonProcess, wait_for

NOBODY = 65534
RATE_HZ = 100.0
PERIOD_NS = round(1e9 / RATE_HZ)
SIGUSR1_MAX_TICKS = 10  # the flag is acted on in the slack after the next tick: 2 nominal, 5x
TRAJECTORY = "t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n"

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="drops to another uid: needs root")


class Owned(DaemonProcess):
    """`run --tcp-port 0` with its socket in a directory others may enter (0711, so that
    only the socket's own mode and the peer check keep them out) and its recording
    directory in tmp_path/rec."""

    def __init__(self, tmp_path: Path, socket_dir: Path, record: bool = False) -> None:
        self.socket = socket_dir / "api.sock"
        self.record = tmp_path / "run.csv"
        self.record_dir = tmp_path / "rec"
        self.stderr = tmp_path / "stderr.txt"
        argv = [sys.executable, "-m", "hand_service.cli", "run", "--no-realtime", "--socket",
                str(self.socket), "--record-dir", str(self.record_dir), "--tcp-port", "0"]
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(argv + (["--record", str(self.record)] if record else []),
                                         stdout=subprocess.PIPE, stderr=err, text=True)
        found = wait_for(lambda: self._port(), 30.0, "the TCP port in the log")
        self.port = int(found)

    def _port(self) -> str | None:
        assert self.proc.poll() is None, self.stderr.read_text()
        match = re.search(r"control API on 127\.0\.0\.1:(\d+)", self.stderr.read_text())
        return match.group(1) if match else None


@contextlib.contextmanager
def socket_dir() -> Iterator[Path]:
    """A directory others may enter but not list or write (0711), in /tmp (1777)."""
    folder = Path(tempfile.mkdtemp(prefix="hand-service-owner-", dir="/tmp"))
    folder.chmod(0o711)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Owned]:
    """One daemon for the tests that only ask it things (it ends DISARMED, not recording)."""
    with socket_dir() as folder:
        process = Owned(tmp_path_factory.mktemp("owner"), folder)
        try:
            yield process
        finally:
            process.close()


def as_nobody(job: Callable[[], Any]) -> Any:
    """job() in a child that has dropped to uid and gid 65534; its JSON result."""
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never back into pytest
        try:
            os.close(read_end)
            os.setgroups([])
            os.setgid(NOBODY)
            os.setuid(NOBODY)
            result = job()
        except BaseException as exc:
            result = {"child_error": repr(exc)}
        with contextlib.suppress(BaseException):
            os.write(write_end, json.dumps(result).encode())
        os._exit(0)
    os.close(write_end)
    with os.fdopen(read_end, "rb") as f:
        data = f.read()
    os.waitpid(pid, 0)
    return json.loads(data)


def _exchange(family: int, address: Any, request: dict[str, Any]) -> dict[str, Any]:
    """Connect, send one request, read until the daemon closes: what came back."""
    try:
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.settimeout(10.0)
        sock.connect(address)
    except OSError as exc:
        return {"connect": type(exc).__name__}
    with sock:
        sock.sendall(json.dumps(request).encode() + b"\n")
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    return {"connect": "ok", "replies": [json.loads(line) for line in data.splitlines()]}


def test_another_user_cannot_command_the_hand_and_the_owner_can(daemon: Owned) -> None:
    token_file = daemon.socket.with_name("api.token")
    with daemon.client() as hand:
        daemon.disarmed(hand)
    assert stat.S_IMODE(os.stat(daemon.socket).st_mode) == 0o600
    assert stat.S_IMODE(os.stat(token_file).st_mode) == 0o600
    token = token_file.read_text().strip()
    assert re.fullmatch(r"[0-9a-f]{64}", token)
    tcp = (socket.AF_INET, ("127.0.0.1", daemon.port))
    unix = (socket.AF_UNIX, str(daemon.socket))

    def attempts() -> dict[str, Any]:
        result: dict[str, Any] = {"uid": os.getuid()}
        try:
            token_file.read_text()
            result["token_file"] = "read"
        except OSError as exc:
            result["token_file"] = type(exc).__name__
        result["unix"] = _exchange(*unix, {"cmd": "arm"})
        result["tcp_no_token"] = _exchange(*tcp, {"cmd": "arm", "id": 1})
        result["tcp_wrong_token"] = _exchange(*tcp, {"cmd": "arm", "token": "0" * 64})
        return result

    seen = as_nobody(attempts)
    assert seen["uid"] == NOBODY, seen
    assert seen["token_file"] == "PermissionError"
    assert seen["unix"] == {"connect": "PermissionError"}  # the socket is 0600
    for case in ("tcp_no_token", "tcp_wrong_token"):
        (reply,) = seen[case]["replies"]  # one error line, then the daemon closed the connection
        assert reply["ok"] is False and reply["error"].startswith("refused: wrong or missing token"), seen

    # were the socket opened to everyone, the peer check still refuses another uid
    daemon.socket.chmod(0o666)
    seen = as_nobody(lambda: _exchange(*unix, {"cmd": "arm"}))
    assert "replies" in seen, seen
    (reply,) = seen["replies"]
    assert reply == {"ok": False, "error": f"refused: uid {NOBODY} is neither the daemon's user (uid 0) "
                                           "nor root"}
    daemon.socket.chmod(0o600)

    with daemon.client() as hand:  # none of it reached the hand; the owner's requests do
        status = hand.status()
        assert status["state"] == "DISARMED" and status["api"]["errors"] == 0
        assert hand.arm() == {"state": "ARMED"}
    with HandClient(daemon.socket, tcp_port=daemon.port) as hand:  # the token read from beside the socket
        assert hand.disarm() == {"state": "DISARMED"}
    assert "refused a connection on the control socket from uid 65534" in daemon.stderr.read_text()

    ctl = [sys.executable, "-m", "hand_service.cli", "ctl", "--socket", str(daemon.socket), "--tcp-port",
           str(daemon.port)]
    done = subprocess.run([*ctl, "status"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "DISARMED" in done.stdout, done.stderr
    wrong = daemon.socket.parent / "wrong.token"
    wrong.write_text("f" * 64 + "\n")
    for extra, piece in ((["--token-file", str(wrong)], "refused: wrong or missing token"),
                         (["--token-file", str(wrong) + ".missing"], "cannot read the daemon's token")):
        done = subprocess.run([*ctl, *extra, "arm"], capture_output=True, text=True, timeout=60)
        assert done.returncode == 2 and done.stderr.count("\n") == 1 and piece in done.stderr, done.stderr


def test_request_paths_stay_in_the_recording_directory(daemon: Owned) -> None:
    rec = daemon.record_dir
    tmp_path = rec.parent
    assert stat.S_IMODE(os.stat(rec).st_mode) == 0o700  # made by the daemon
    secret = tmp_path / "secret.csv"
    secret.write_text("t,angle_ref_deg_index\n0,0\n1,SECRET-VALUE\n")
    (rec / "escape.csv").symlink_to(secret)
    (rec / "out").symlink_to(tmp_path, target_is_directory=True)
    (rec / "ok.csv").write_text(TRAJECTORY)
    (rec / "bad-header.csv").write_text("t,SECRET-HEADER\n0,0\n1,0\n")
    (rec / "bad-cell.csv").write_text("t,angle_ref_deg_index\n0,0\n1,SECRET-CELL\n")
    refused = {
        ("load_trajectory", "/etc/passwd"): "outside the data directory",
        ("load_trajectory", f"{rec}/../secret.csv"): "outside the data directory",
        ("load_trajectory", f"{rec}/escape.csv"): "outside the data directory",
        ("record_start", f"{rec}/../made.csv"): "outside the data directory",
        ("record_start", f"{rec}/out/made.csv"): "outside the data directory",
        ("record_start", "/made.csv"): "outside the data directory",
        ("record_start", f"{rec}/new/sub/made.csv"): "its directory does not exist",
        ("load_trajectory", f"{rec}/bad-header.csv"): f"{rec}/bad-header.csv:1: unknown column",
        ("load_trajectory", f"{rec}/bad-cell.csv"): f"{rec}/bad-cell.csv:3: column 'angle_ref_deg_index': "
                                                    "not a number",
    }
    with daemon.client() as hand:
        daemon.disarmed(hand)
        for (cmd, path), piece in refused.items():
            with pytest.raises(ApiError) as info:
                hand.request(cmd, path=path)
            error = str(info.value)
            assert piece in error and "\n" not in error and "SECRET" not in error, (cmd, path, error)
        assert not (tmp_path / "made.csv").exists() and not Path("/made.csv").exists()
        assert not (rec / "new").exists()  # no directory is made for a request
        assert hand.load_trajectory(rec / "ok.csv")["ticks"] == 101
        started = hand.record_start(rec / "mine.csv")
        assert started["active"] and started["path"] == str(rec / "mine.csv")
        hand.record_stop()

    ctl = [sys.executable, "-m", "hand_service.cli", "ctl", "--socket", str(daemon.socket), "record-start"]
    done = subprocess.run([*ctl, "/nonexistent/dir/x.csv"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "outside the data directory" in done.stderr and not Path("/nonexistent").exists()


@pytest.mark.parametrize(("text", "said"), [
    ("t,SECRET\n0,0\n1,0\n", ":1: unknown column"),
    ("t,angle_ref_deg_index\n0,0\n1,SECRET\n", ":3: column 'angle_ref_deg_index': not a number"),
    ("t,angle_ref_deg_index\n0,0\n1,1e999\n", ":3: column 'angle_ref_deg_index': not a finite number"),
    ("t,angle_ref_deg_index\n0,0\n1,9999\n", ":3: column 'angle_ref_deg_index': outside the profile's target "
                                              "range [0, 180] deg"),
    ("t,angle_ref_deg_index\n0,0\n1,0,SECRET\n", ":3: the row does not have as many fields as the header"),
    ("t,angle_ref_deg_index\n0.5,0\n0.25,0\n", ":3: column 't': t does not increase"),
    ("angle_ref_deg_index\n0\n", ":1: missing required column 't'"),
    ("t,angle_ref_deg_index\n0,0\n1,\"SECRET\n", ":3: column 'angle_ref_deg_index': not a number"),
    (b"t,angle_ref_deg_index\n0,0\n1,SECRET\xff\n", ": not UTF-8 text"),
    ("t,angle_ref_deg_index\n0,SECRET\n", ":2: column 'angle_ref_deg_index': not a number"),
    ("t,angle_ref_deg_index\n0,0\n", ": a trajectory needs a header and at least two rows"),
])
def test_a_trajectory_error_says_where_and_what_not_the_text(tmp_path: Path, text: str | bytes,
                                                             said: str) -> None:
    """Every reader error the API passes on (redact.py), on a file whose cells are secret."""
    from hand_service.api.redact import trajectory_error
    from hand_service.config.profile import load_profile
    from hand_service.errors import UserError
    from hand_service.service.trajectory_csv import read_trajectory

    path = tmp_path / "t.csv"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    profile = load_profile(None)
    with pytest.raises(UserError) as info:
        read_trajectory(path, profile)
    told = trajectory_error(str(info.value), str(path), profile)
    assert told.startswith(f"{path}{said}"), (str(info.value), told)
    assert "SECRET" not in told and "\n" not in told


def _refused_start(tmp_path: Path, capsys: pytest.CaptureFixture[str], socket_path: Path, *extra: str) -> str:
    """`hand-service run` (in this process: it stops before its loop) refused: exit status 2,
    one line, and neither the socket nor the token file left behind."""
    capsys.readouterr()
    code = main(["run", "--no-realtime", "--socket", str(socket_path), "--record-dir", str(tmp_path / "rec"),
                 "--duration", "1", *extra])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("hand-service run: error: "), err
    assert not socket_path.exists() and not socket_path.with_name("api.token").exists()
    return err


def test_a_socket_directory_others_may_write_or_own_is_refused(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    assert "writable by no one else; it is owned by uid 0 with mode 0777" in _refused_start(
        tmp_path, capsys, shared / "api.sock")
    theirs = tmp_path / "theirs"
    theirs.mkdir(mode=0o700)
    os.chown(theirs, NOBODY, NOBODY)
    assert f"it is owned by uid {NOBODY} with mode 0700" in _refused_start(tmp_path, capsys,
                                                                            theirs / "api.sock")
    below = tmp_path / "open" / "private"
    below.mkdir(parents=True, mode=0o700)
    (tmp_path / "open").chmod(0o777)  # another user could move `private` away and put theirs there
    assert "above the control socket" in _refused_start(tmp_path, capsys, below / "api.sock")


def test_a_failed_start_leaves_no_socket_behind(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The socket and the token are made, then the TCP port is taken: both are removed."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        line = _refused_start(tmp_path, capsys, tmp_path / "run" / "api.sock", "--tcp-port", str(port))
    assert f"cannot listen on 127.0.0.1:{port}" in line


def test_sigusr1_vents_the_hand(tmp_path: Path) -> None:
    with socket_dir() as folder:
        daemon = Owned(tmp_path, folder, record=True)
        try:
            _sigusr1(daemon)
        finally:
            daemon.close()


def _sigusr1(daemon: Owned) -> None:
    with daemon.client() as hand:
        daemon.disarmed(hand)
        hand.arm()
        hand.target("all", angle_deg=40.0)
        hand.start()
        time.sleep(1.0)
        t0 = hand.status()["tick"]
        c1 = time.monotonic_ns()
        daemon.proc.send_signal(signal.SIGUSR1)
        sent = t0 + (time.monotonic_ns() - c1) // PERIOD_NS  # the least tick the daemon was at
        wait_for(lambda: hand.status()["state"] == "ESTOP", 5.0, "ESTOP after SIGUSR1")
        time.sleep(0.3)  # ticks in ESTOP, recorded
    assert daemon.terminate() == 0
    assert "SIGUSR1: emergency stop (RUNNING -> ESTOP)" in daemon.stderr.read_text()
    rec = read_recording(daemon.record, finger="index")
    ticks = np.rint(rec.t_s * RATE_HZ).astype(np.int64)
    states = np.array(rec.text_columns["state"])
    acted = int(ticks[(ticks > t0) & (states == "ESTOP")][0])
    print(f"\nSIGUSR1 -> ESTOP: {acted - sent} ticks")
    assert acted - sent <= SIGUSR1_MAX_TICKS
    assert rec.columns["pressure_kpa"][ticks == acted][0] == 0.0
    assert np.all(states[ticks >= acted][:-1] == "ESTOP")  # latched, to the shutdown row
