"""The control API's requests: each validated against the profile, then applied to the
supervisor between ticks. One request is a JSON object with a `cmd`; the reply is
{"ok": true, "result": ...} or {"ok": false, "error": "one clear line"}. See docs/api.md.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.api.impedance import gain_limits, impedance_gains
from hand_service.api.paths import confine, new_file_in
from hand_service.api.redact import trajectory_error
from hand_service.api.server import Deferred
from hand_service.api.state_table import followed_from
from hand_service.config.profile import Profile
from hand_service.config.textfile import show
from hand_service.errors import UserError
from hand_service.service.background import Background
from hand_service.service.states import State, TransitionError
from hand_service.service.surface import HandControl
from hand_service.service.trajectory import Trajectory
from hand_service.service.trajectory_csv import read_trajectory
from hand_service.version import software_version
from rtcore.config import MODE_NAMES, MODES_BY_NAME

log = logging.getLogger(__name__)


class RequestError(Exception):
    """A request the daemon refuses; the message is the reply's error."""


PATH = "path"  # Param.kind of a file path: text the operating system can take


@dataclass(frozen=True)
class Param:
    kind: type | str  # str, float, bool or PATH
    required: bool = True
    doc: str = ""


def _number(name: str, value: Any) -> float:
    """A finite number (an integer too large for a double is not one)."""
    if not isinstance(value, bool) and isinstance(value, (int, float)):
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if math.isfinite(number):
            return number
    raise RequestError(f"'{name}' must be a finite number, not {show(value)}")


def _path(name: str, value: str) -> str:
    """A path the operating system can take: no NUL, encodable (no lone surrogate)."""
    try:
        os.fsencode(value)
    except UnicodeError:
        raise RequestError(f"'{name}' is not a usable path: it holds a character that is not text") from None
    if "\0" in value:
        raise RequestError(f"'{name}' is not a usable path: it holds a NUL")
    return value


def parse_request(request: Any, table: dict[str, tuple[dict[str, Param], Callable[..., Any]]]
                  ) -> tuple[str, dict[str, Any]]:
    """The request's cmd and its arguments, every one of the type its Param says; a
    RequestError of one line for anything else (docs/api.md)."""
    if not isinstance(request, dict):
        raise RequestError("a request is a JSON object with a 'cmd'")
    cmd = request.get("cmd")
    if not isinstance(cmd, str) or cmd not in table:
        raise RequestError(f"unknown cmd {show(cmd)} (known: {', '.join(sorted(table))})")
    params = table[cmd][0]
    args: dict[str, Any] = {}
    for key, value in request.items():
        if key in ("cmd", "id"):
            continue
        if key not in params:
            known = ", ".join(params) or "none"
            raise RequestError(f"{cmd}: unknown parameter {_name(key)} (parameters: {known})")
        spec = params[key]
        if spec.kind is float:
            args[key] = _number(key, value)
            continue
        kind = str if spec.kind == PATH else spec.kind
        assert isinstance(kind, type)
        if not isinstance(value, kind):
            raise RequestError(f"{cmd}: '{key}' must be {kind.__name__}, not {show(value)}")
        args[key] = _path(key, value) if spec.kind == PATH else value
    missing = [k for k, p in params.items() if p.required and k not in args]
    if missing:
        raise RequestError(f"{cmd}: missing parameter '{missing[0]}' ({params[missing[0]].doc})")
    return cmd, args


def _name(text: object) -> str:
    """'text' for a message: quoted if it prints on one line, else its shortened repr."""
    return f"'{text}'" if isinstance(text, str) and text.isprintable() and len(text) <= 40 else show(text)


def _parse_trajectory(path: str, profile: Profile, rate_hz: float) -> tuple[Trajectory, np.ndarray]:
    """In the worker: read, resample and check the file; the fingers it drives. A parse
    error says where and what, never the file's text (redact.py)."""
    try:
        traj = read_trajectory(path, profile, rate_hz)
    except UserError as exc:
        raise UserError(trajectory_error(str(exc), path, profile)) from None
    return traj, traj.checked_driven()


@dataclass
class _Loading:
    """A load_trajectory in progress: its worker, and its reply once poll() has it."""

    job: Background[tuple[Trajectory, np.ndarray]]
    path: str
    finish: Callable[[], dict[str, Any]]
    head: dict[str, Any] = field(default_factory=dict)
    cmd: Any = None
    reply: dict[str, Any] | None = None


class Api:
    """Request name -> (parameters, handler). `handle(request)` never raises."""

    def __init__(self, supervisor: HandControl, metadata: Callable[[], dict[str, object]],
                 record_dir: Path | None = None) -> None:
        self.sup = supervisor
        self.metadata = metadata
        # the real path of the only directory a request's path may name (None: no path is taken)
        self.record_dir = record_dir
        self.requests = 0
        self.errors = 0
        self._loading: _Loading | None = None
        self.table: dict[str, tuple[dict[str, Param], Callable[..., Any]]] = {
            "status": ({}, self.status),
            "params": ({}, self.params),
            "faults": ({}, self.faults),
            "arm": ({}, lambda: self._state(self.sup.arm())),
            "disarm": ({}, lambda: self._state(self.sup.disarm())),
            "start": ({}, lambda: self._state(self.sup.start())),
            "hold": ({}, lambda: self._state(self.sup.hold())),
            "resume": ({}, lambda: self._state(self.sup.resume())),
            "estop": ({}, lambda: self._state(self.sup.estop())),
            "reset": ({}, lambda: self._state(self.sup.reset())),
            "mode": ({"finger": Param(str, doc="finger name or 'all'"),
                      "mode": Param(str, doc="vent | pressure | position | force | impedance"),
                      "stiffness_n_per_deg": Param(float, False, doc="impedance: virtual stiffness"),
                      "damping_n_s_per_deg": Param(float, False, doc="impedance: virtual damping")},
                     self.mode),
            "target": ({"finger": Param(str, doc="finger name or 'all'"),
                        "angle_deg": Param(float, False), "force_n": Param(float, False),
                        "pressure_kpa": Param(float, False)}, self.target),
            "load_trajectory": ({"path": Param(PATH, doc="absolute path of a trajectory CSV in the "
                                                         "data directory"),
                                 "loop": Param(bool, False)}, self.load_trajectory),
            "clear_trajectory": ({}, self.clear_trajectory),
            "record_start": ({"path": Param(PATH, doc="absolute path of a new CSV in the data "
                                                      "directory")}, self.record_start),
            "record_stop": ({}, self.record_stop),
        }

    # -- dispatch ---------------------------------------------------------------------
    def handle(self, request: Any) -> dict[str, Any] | Deferred:
        self.requests += 1
        head: dict[str, Any] = {}
        if isinstance(request, dict) and "id" in request:
            head["id"] = request["id"]
        cmd = request.get("cmd") if isinstance(request, dict) else None
        return self._answer(head, cmd, lambda: self._dispatch(request))

    def _answer(self, head: dict[str, Any], cmd: Any, call: Callable[[], Any]) -> dict[str, Any] | Deferred:
        """The reply to call(): its result, its refusal, or (a bug) an internal error; a
        Deferred when the work goes on in the background."""
        reply = dict(head)
        try:
            result = call()
        except (RequestError, TransitionError, UserError) as exc:
            self.errors += 1
            reply.update(ok=False, error=str(exc))
        except Exception as exc:  # a bug in a handler must not stop the loop that vents
            self.errors += 1
            log.exception("request %r failed", cmd)
            reply.update(ok=False, error=f"{cmd}: internal error: {type(exc).__name__}: {exc}")
        else:
            if isinstance(result, _Loading):
                result.head, result.cmd = head, cmd
                return Deferred(lambda: result.reply)
            reply.update(ok=True, result=result)
        return reply

    def poll(self) -> None:
        """In the slack: take a trajectory its worker has parsed (the reply is then ready)."""
        loading = self._loading
        if loading is None or not loading.job.done:
            return
        self._loading = None
        answer = self._answer(loading.head, loading.cmd, loading.finish)
        assert isinstance(answer, dict)
        loading.reply = answer

    def _dispatch(self, request: Any) -> Any:
        cmd, args = parse_request(request, self.table)
        return self.table[cmd][1](**args)

    # -- helpers ------------------------------------------------------------------------
    def _fingers(self, name: str) -> list[int]:
        names = self.sup.names
        if name == "all":
            return list(range(len(names)))
        if name not in names:
            raise RequestError(f"unknown finger {_name(name)} (fingers: {', '.join(names)}, all)")
        return [names.index(name)]

    @staticmethod
    def _state(state: State) -> dict[str, str]:
        return {"state": state.name}

    def _not_driven(self, fingers: list[int], what: str) -> None:
        driven = [self.sup.names[i] for i in self.sup.trajectory_drives(fingers)]
        if not driven:
            return
        state = self.sup.state
        playing = state in (State.RUNNING, State.HOLD)
        then = "hold, then clear the trajectory" if state is State.RUNNING else "clear the trajectory"
        raise RequestError(f"{what}: in {state.name}, {', '.join(driven)} follow the trajectory "
                           f"{'playing' if playing else 'loaded (start plays it)'}; {then} first "
                           "(ctl clear-trajectory)")

    # -- requests -----------------------------------------------------------------------
    def mode(self, finger: str, mode: str, stiffness_n_per_deg: float | None = None,
             damping_n_s_per_deg: float | None = None) -> dict[str, Any]:
        fingers = self._fingers(finger)
        if mode not in MODES_BY_NAME:
            raise RequestError(f"mode must be one of {', '.join(MODES_BY_NAME)}, not {show(mode)}")
        limits = {self.sup.names[i]: gain_limits(self.sup.profile.fingers[i].model) for i in fingers}
        gains = impedance_gains(mode, stiffness_n_per_deg, damping_n_s_per_deg, limits)
        self._not_driven(fingers, "mode")
        reply: dict[str, Any] = {"fingers": [self.sup.names[i] for i in fingers], "mode": mode,
                                 "applies": followed_from(self.sup.state)}
        if gains is not None:
            reply.update(stiffness_n_per_deg=gains[0], damping_n_s_per_deg=gains[1])
        self.sup.set_mode(fingers, MODES_BY_NAME[mode], gains)
        return reply

    def target(self, finger: str, angle_deg: float | None = None, force_n: float | None = None,
               pressure_kpa: float | None = None) -> dict[str, Any]:
        given = {k: v for k, v in (("angle_deg", angle_deg), ("force_n", force_n),
                                   ("pressure_kpa", pressure_kpa)) if v is not None}
        if len(given) != 1:
            raise RequestError("target: give exactly one of angle_deg, force_n, pressure_kpa")
        fingers = self._fingers(finger)
        self._not_driven(fingers, "target")
        safety = self.sup.profile.safety
        (key, value), = given.items()
        for i in fingers:
            if key == "angle_deg":
                low, high = safety["target_angle_min_deg"], safety["target_angle_max_deg"]
            elif key == "force_n":
                low, high = safety["target_force_min_n"], safety["target_force_max_n"]
            else:
                f = self.sup.profile.fingers[i]
                low, high = f.pressure_min_kpa, f.pressure_max_kpa
            if not low <= value <= high:
                raise RequestError(f"target: {key} = {value:g} is outside [{low:g}, {high:g}] for "
                                   f"{self.sup.names[i]} (profile)")
        after = self.sup.set_target(fingers, key, value)
        modes = {self.sup.names[i]: MODE_NAMES[m] for i, m in zip(fingers, after, strict=True)}
        shown: str | dict[str, str] = next(iter(modes.values())) if len(set(modes.values())) == 1 else modes
        return {"fingers": [self.sup.names[i] for i in fingers], key: value, "mode": shown,
                "applies": followed_from(self.sup.state)}

    def load_trajectory(self, path: str, loop: bool = False) -> _Loading:
        """Parsed in a worker thread (an hour of trajectory takes seconds, which the loop
        must not stop for while pressurised); poll() applies it between ticks, and the
        reply comes then."""
        self._not_running("load_trajectory")
        path = confine("load_trajectory", path, self.record_dir)
        if self._loading is not None:
            raise RequestError(f"load_trajectory: {self._loading.path} is still loading")
        job = Background(_parse_trajectory, path, self.sup.profile, self.sup.rate_hz, name="trajectory")
        self._loading = _Loading(job, path, lambda: self._loaded(*job.result(), path, loop))
        return self._loading

    def _not_running(self, what: str) -> None:
        if self.sup.state is State.RUNNING:
            raise RequestError(f"{what}: not in RUNNING; hold or disarm first")

    def _loaded(self, traj: Trajectory, driven: np.ndarray, path: str, loop: bool) -> dict[str, Any]:
        self._not_running("load_trajectory")  # the state may have changed while it loaded
        self.sup.set_trajectory(traj, loop, driven)
        return {"path": path, "duration_s": traj.duration_s, "ticks": traj.n_ticks, "loop": loop,
                "fingers": [n for n, d in zip(self.sup.names, driven, strict=True) if d],
                "applies": followed_from(self.sup.state)}

    def clear_trajectory(self) -> dict[str, Any]:
        playing = self.sup.trajectory_status()
        if self.sup.state is State.RUNNING and playing is not None and not playing.done:
            raise RequestError("clear_trajectory: not in RUNNING while the trajectory plays; hold first")
        self.sup.clear_trajectory()
        return {"trajectory": None}

    def record_start(self, path: str) -> dict[str, Any]:
        return self.sup.start_recording(new_file_in("record_start", path, self.record_dir), self.metadata())

    def record_stop(self) -> dict[str, Any]:
        stopped = self.sup.stop_recording()
        if stopped is None:
            raise RequestError("record_stop: not recording (ctl record-start starts one)")
        return stopped

    def faults(self) -> dict[str, Any]:
        history = self.sup.fault_history()
        return {"counts": history.counts, "total": history.total,
                "faults": [f.as_dict() for f in history.faults]}

    def params(self) -> dict[str, Any]:
        prof = self.sup.profile
        return {
            "profile": prof.name, "path": str(prof.path), "software_version": software_version(),
            "rate_hz": self.sup.rate_hz, "transport": dict(prof.transport),
            "control": prof.control.as_dict(), "safety": dict(prof.safety),
            "fingers": {f.name: {"pressure_min_kpa": f.pressure_min_kpa,
                                 "pressure_max_kpa": f.pressure_max_kpa,
                                 "stiffness_nm_per_rad": f.model.stiffness_nm_per_rad,
                                 "damping_nms_per_rad": f.model.damping_nms_per_rad,
                                 "pressure_gain_nm_per_kpa": f.model.pressure_gain_nm_per_kpa,
                                 "inertia_kgm2": f.model.inertia_kgm2,
                                 "lever_arm_m": f.model.lever_arm_m,
                                 "kp_kpa_per_deg": f.kp_kpa_per_deg,
                                 "ki_kpa_per_deg_s": f.ki_kpa_per_deg_s,
                                 "kd_kpa_s_per_deg": f.kd_kpa_s_per_deg,
                                 "force_kp_kpa_per_n": f.force_kp_kpa_per_n,
                                 "force_ki_kpa_per_n_s": f.force_ki_kpa_per_n_s}
                        for f in prof.fingers},
        }

    def status(self) -> dict[str, Any]:
        """The supervisor's snapshot, with the API's own part after its trajectory and
        its transport."""
        reply: dict[str, Any] = {}
        for key, value in self.sup.status().as_dict().items():
            reply[key] = value
            if key == "trajectory":
                reply["trajectory_loading"] = None if self._loading is None else self._loading.path
            elif key == "transport":
                reply["api"] = {"requests": self.requests, "errors": self.errors}
        reply["data_dir"] = None if self.record_dir is None else str(self.record_dir)
        return reply
