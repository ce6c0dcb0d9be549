"""The inputs the probes found, each refused in one clear line or accepted as documented."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hand_service import cli
from hand_service.api.requests import Api
from hand_service.api.server import ApiServer
from hand_service.config.profile import load_model, load_profile
from hand_service.errors import UserError
from hand_service.recording import read_recording
from hand_service.service.recorder import Recorder
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from hand_service.service.trajectory_csv import read_trajectory
from hand_service.transports.sim import SimTransport
from tests.fuzz.conftest import MODEL_TEXT, PROFILE_TEXT, RECORDING_TEXT
from tests.service.conftest import Rig


def refused(call: object, *pieces: str) -> str:
    """The UserError's message: one line, holding every piece."""
    with pytest.raises(UserError) as info:
        call()  # type: ignore[operator]
    message = str(info.value)
    assert "\n" not in message, message
    for piece in pieces:
        assert piece in message, message
    return message


# -- recordings -----------------------------------------------------------------------------
@pytest.mark.parametrize(("name", "encode"), [
    ("BOM", lambda text: b"\xef\xbb\xbf" + text.encode()),
    ("CRLF", lambda text: text.replace("\n", "\r\n").encode()),
    ("BOM and CRLF", lambda text: b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode()),
    ("CR", lambda text: text.replace("\n", "\r").encode()),
    ("UTF-16", lambda text: text.encode("utf-16")),
])
def test_a_recording_saved_by_another_tool_reads_the_same(tmp_path: Path, name: str, encode: object) -> None:
    plain, other = tmp_path / "plain.csv", tmp_path / "other.csv"
    plain.write_text(RECORDING_TEXT)
    other.write_bytes(encode(RECORDING_TEXT))  # type: ignore[operator]
    expected, got = read_recording(plain), read_recording(other)
    np.testing.assert_array_equal(got.t_s, expected.t_s)
    np.testing.assert_array_equal(got.angle_deg, expected.angle_deg)
    assert got.metadata == expected.metadata and got.text_columns == expected.text_columns


def test_a_header_holding_a_bom_in_the_middle_is_still_refused(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    path.write_text("\ufeff" + RECORDING_TEXT.replace("# finger: index\n", "# finger: index\n\ufeff"))
    refused(lambda: read_recording(path), "missing required column 't'")


def test_a_recording_that_is_not_utf8_names_its_line(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    path.write_bytes(RECORDING_TEXT.encode().replace(b"0.0100", b"0.01\xff0"))
    refused(lambda: read_recording(path), f"{path}:5: not UTF-8 text (byte 0xff")


# -- profiles and models ----------------------------------------------------------------------
@pytest.mark.parametrize(("old", "new", "pieces"), [
    ("rate_hz: 100", "rate_hz: !!int 1e3", (":8: cannot read '1e3' as int",)),
    ("kind: sim", "kind: [sim]", (":6: transport.kind must be one of can, serial, sim, not ['sim']",)),
    ("kind: sim", "kind: {a: 1}", ("transport.kind must be one of",)),
    ("rate_hz: 100", "rate_hz: " + "9" * 400,
     (":8: control.rate_hz = 9999", "is out of range (10 ≤ x ≤ 1000)")),
    ("rate_hz: 100", "rate_hz: " + "9" * 5000, (":8: cannot read", "as int (ValueError)")),
    ("rate_hz: 100", "rate_hz: 1e400", (":8: control.rate_hz must be finite, not inf",)),
    ("seed: 1", "seed: !!python/object:os.system ''", ("could not determine a constructor",)),
    ("seed: 1", "seed: !!timestamp x", ('failed to construct timestamp from "x"',)),
    ("seed: 1", "seed: " + "[" * 3000 + "]" * 3000, ("nested too deeply",)),
    ("seed: 1", "? [a, b]: 1", ("is not a name: every key is text",)),
    ("seed: 1", "1: 2", ("key 1 is not a name",)),
    ("seed: 1", "<<: 1", ("expected a mapping or list of mappings for merging",)),
    ("seed: 1", "seed: \x07", ("the character '\\x07' is not allowed in YAML",)),
    ("filter_order: 2", "filter_order: 3", ("control.filter_order = 3 is out of range (2 or 4)",)),
    ("  index:\n", "  all:\n", ("the finger name 'all' must be",)),
    ("  index:\n", "  'in,dex':\n", ("the finger name 'in,dex' must be",)),
    ("sensor_gain_deg_per_mv: 0.1", "sensor_gain_deg_per_mv: 0", ("sensor_gain_deg_per_mv must not be 0",)),
    ("length_m: 0.095", "length_m: 1.0e+300", ("give an inertia of inf",)),
    ("target_force_max_n: 10.0", "target_force_max_n: 10.0\n  target_force_min_n: -11",
     ("target_force_min_n must not be below -target_force_max_n",)),
])
def test_profile_mistakes_the_fuzzing_found_are_one_line(tmp_path: Path, old: str, new: str,
                                                         pieces: tuple[str, ...]) -> None:
    assert old in PROFILE_TEXT, old
    path = tmp_path / "profile.yaml"
    path.write_text(PROFILE_TEXT.replace(old, new, 1))
    refused(lambda: load_profile(path), str(path), *pieces)


@pytest.mark.parametrize(("data", "piece"), [
    (PROFILE_TEXT.encode().replace(b"description: ", b"description: caf\xe9 "),
     ":2: not UTF-8 text (byte 0xe9"),
    (b"\xff\xfe\x00\xd8", ":1: not UTF-16 text"),
    (b"profile: x\x00\n", ":1: a NUL byte in the text (UTF-16 without a byte-order mark?)"),
])
def test_a_profile_that_is_not_text_is_one_line(tmp_path: Path, data: bytes, piece: str) -> None:
    path = tmp_path / "profile.yaml"
    path.write_bytes(data)
    refused(lambda: load_profile(path), f"{path}{piece}")


def test_a_profile_saved_with_a_bom_and_crlf_loads(tmp_path: Path) -> None:
    path = tmp_path / "profile.yaml"
    path.write_bytes(b"\xef\xbb\xbf" + PROFILE_TEXT.replace("\n", "\r\n").encode())
    assert load_profile(path).finger_names == ["index"]


def test_an_include_that_is_a_fifo_is_refused_unread(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "base.yaml")
    path = tmp_path / "bus.yaml"
    path.write_text("profile: bus\nprotocol_version: 1\ninclude: base.yaml\ntransport: {kind: sim}\n")
    refused(lambda: load_profile(path), "is not a regular file")


@pytest.mark.parametrize(("text", "piece"), [
    ("transport:\n  kind: can\n  interface: virtual\n  channel: probe\n  dbc: :{long}\n", "transport.dbc"),
    ("include: {long}.yaml\ntransport: {{kind: sim}}\n", ":3: include"),
])
def test_a_name_too_long_to_look_up_is_one_line(tmp_path: Path, text: str, piece: str) -> None:
    """Found by the profile fuzzer (a CI run): a dbc of 400 characters made Path.exists raise
    OSError (file name too long) instead of refusing the profile; an include and the
    profile's own name went the same way (config.textfile.lookup)."""
    path = tmp_path / "bus.yaml"
    path.write_text("profile: bus\nprotocol_version: 1\n" + text.format(long="9" * 400))
    message = refused(lambda: load_profile(path), piece, "File name too long")
    assert len(message) < 300
    refused(lambda: load_profile("9" * 400), "cannot look it up: File name too long")


@pytest.mark.parametrize(("old", "new", "piece"), [
    ("gamma: 0.85", "gamma: !!float abc", ":8: cannot read 'abc' as float"),
    ("inertia_kgm2: 1.617e-4 ", "inertia_kgm2: " + "1" * 400, "inertia_kgm2 = 1111111111"),
    ("tau_s: 0.03", "tau_s: " + "9" * 400, "effects.valve_lag.tau_s = 999999999"),
    ("finger: index ", "finger: [index]", "finger must be text, not ['index']"),
])
def test_model_mistakes_are_one_line(tmp_path: Path, old: str, new: str, piece: str) -> None:
    assert old in MODEL_TEXT, old
    path = tmp_path / "model.yaml"
    path.write_text(MODEL_TEXT.replace(old, new, 1))
    message = refused(lambda: load_model(path), str(path), piece)
    assert len(message) < 300


# -- trajectories ---------------------------------------------------------------------------
PROFILE = load_profile(None)


@pytest.mark.parametrize(("text", "piece"), [
    ("t,angle_ref_deg_index\n0,0\n1e400,1\n", ":3: column 't': '1e400' where a finite number is required"),
    ("t,angle_ref_deg_index\n0,0\n1,1e400\n", ":3: column 'angle_ref_deg_index': '1e400' where a finite"),
    ("t,angle_ref_deg_index\n-1e308,0\n1e308,1\n", ":3: column 't': inf s at 100 Hz is inf ticks"),
    ("t,angle_ref_deg_index\n0,0\n1.7976931348623157e308,1\n", ":3: column 't': 1.79769e+308 s at 100 Hz"),
    ("t,force_ref_n_index\n0,0\n1,-5\n", ":3: column 'force_ref_n_index': -5 N is outside the profile's "
                                         "target range [0, 10] N"),
])
def test_trajectory_mistakes_are_one_line(tmp_path: Path, text: str, piece: str) -> None:
    path = tmp_path / "traj.csv"
    path.write_text(text)
    refused(lambda: read_trajectory(path, PROFILE, 100.0), f"{path}{piece}")


def test_a_trajectory_with_a_bom_and_crlf_loads(tmp_path: Path) -> None:
    path = tmp_path / "traj.csv"
    path.write_bytes(b"\xef\xbb\xbft,angle_ref_deg_index\r\n0,0\r\n1,10\r\n")
    assert read_trajectory(path, PROFILE, 100.0).n_ticks == 101


# -- the control API and ctl --------------------------------------------------------------------
@pytest.fixture
def api() -> Api:
    rig = Rig()
    rig.tick()
    return Api(rig.sup, metadata=dict)


@pytest.mark.parametrize(("request_", "piece"), [
    ({"cmd": {"a": 1}}, "unknown cmd {'a': 1} (known: arm,"),
    ({"cmd": ["status"]}, "unknown cmd ['status']"),
    ({"cmd": "target", "finger": "index", "angle_deg": 10**400},
     "'angle_deg' must be a finite number, not 1000"),
    ({"cmd": "target", "finger": "index", "force_n": -5},
     "target: force_n = -5 is outside [0, 10] for index"),
    ({"cmd": "target", "finger": ["index"], "angle_deg": 1}, "target: 'finger' must be str, not ['index']"),
    ({"cmd": "target", "finger": "in\ndex", "angle_deg": 1}, "unknown finger 'in\\ndex'"),
    ({"cmd": "mode", "finger": "index", "mode": {"a": 1}}, "mode: 'mode' must be str, not {'a': 1}"),
    ({"cmd": "status", "a\nb": 1}, "status: unknown parameter 'a\\nb'"),
    ({"cmd": "load_trajectory", "path": "/tmp/a\x00b"}, "'path' is not a usable path: it holds a NUL"),
    ({"cmd": "record_start", "path": "/tmp/\ud800.csv"}, "'path' is not a usable path: it holds a character"),
    ({"cmd": "load_trajectory", "path": "/tmp/t.csv", "loop": "yes"}, "'loop' must be bool, not 'yes'"),
])
def test_bad_requests_get_a_clear_error_reply(api: Api, request_: dict[str, object], piece: str) -> None:
    reply = api.handle(request_)
    assert isinstance(reply, dict) and reply["ok"] is False, reply
    assert piece in reply["error"] and "\n" not in reply["error"] and "internal error" not in reply["error"]


def test_a_profile_may_allow_negative_force_targets(api: Api) -> None:
    api.sup.profile.safety["target_force_min_n"] = -2.0
    assert api.handle({"cmd": "target", "finger": "index", "force_n": -1.5})["ok"]  # type: ignore[index]
    reply = api.handle({"cmd": "target", "finger": "index", "force_n": -5})
    assert "outside [-2, 10]" in reply["error"]  # type: ignore[index]


@pytest.fixture
def socket_path(tmp_path: Path, api: Api) -> Iterator[Path]:
    """The Api served on a socket by a thread, as the daemon's loop would."""
    path = tmp_path / "api.sock"
    server = ApiServer(api.handle, path)
    server.open()
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            server.poll()
            stop.wait(0.002)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield path
    stop.set()
    thread.join(5.0)
    for sock in server.listeners:
        sock.close()


@pytest.mark.parametrize(("flags", "piece"), [
    (["--force-n", "-5"], "force_n = -5 is outside [0, 10] for index (profile)"),
    (["--force-n", "11"], "force_n = 11 is outside [0, 10] for index (profile)"),
    (["--angle-deg", "1e6"], "angle_deg = 1e+06 is outside [0, 180] for index (profile)"),
    (["--pressure-kpa", "-50"], "pressure_kpa = -50 is outside [0, 200] for index (profile)"),
    (["--angle-deg", "nan"], "--angle-deg must be a finite number, not nan"),
    (["--force-n", "1e400"], "--force-n must be a finite number, not inf"),
    (["--pressure-kpa=-inf"], "--pressure-kpa must be a finite number, not -inf"),
])
def test_ctl_refuses_absurd_targets_in_one_line(socket_path: Path, capsys: pytest.CaptureFixture[str],
                                                flags: list[str], piece: str) -> None:
    code = cli.main(["ctl", "--socket", str(socket_path), "target", "index", *flags])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("hand-service ctl: error: ") and piece in err, err


def test_ctl_accepts_a_target_within_the_profile(socket_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["ctl", "--socket", str(socket_path), "target", "index", "--force-n", "1.5"]) == 0
    assert "force_n: 1.5" in capsys.readouterr().out


# -- the recording's last row ---------------------------------------------------------------------
def test_the_vented_last_row_says_shutdown(tmp_path: Path) -> None:
    """SIGTERM while RUNNING: the loop's last tick vents every finger, and its row's state
    is SHUTDOWN, not the RUNNING the loop was in."""
    profile = load_profile(None)
    recorder = Recorder(profile.finger_names, 100.0, "thread")
    sup = Supervisor(profile, SimTransport(profile, seed=3), recorder)
    signal_after = 60

    def drive(_slack_ns: int) -> None:
        if sup.state is State.DISARMED:
            sup.fire(Event.ARM)
        elif sup.state is State.ARMED:
            sup.targets.mode[:] = 2  # position
            sup.targets.angle_deg[:] = 40.0
            sup.fire(Event.START)
        elif sup.stats.ticks >= signal_after:
            sup.request_stop(signal.Signals.SIGTERM.name)  # what the signal handler does

    sup.slack.append(drive)
    path = tmp_path / "run.csv"
    recorder.start(path, {"test": "vented last row"})
    sup.run(max_ticks=10 * signal_after)
    assert sup.stop_reason == "SIGTERM"
    for finger in profile.finger_names:
        rec = read_recording(path, finger=finger, min_duration_s=0.0)
        assert rec.text_columns["state"][-2] == "RUNNING" and np.max(rec.pressure_kpa) > 5.0
        assert rec.text_columns["state"][-1] == "SHUTDOWN"
        assert rec.pressure_kpa[-1] == 0.0 and rec.text_columns["mode"][-1] == "vent"
