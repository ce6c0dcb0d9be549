"""From the command line's port and profile to the Settings and the BoardLink the check uses."""

from __future__ import annotations

import math
from typing import Any

import can
import serial

from hand_service.boardcheck.link import BoardLink, CanBoardLink, SerialBoardLink
from hand_service.boardcheck.sense import FingerSense
from hand_service.boardcheck.session import Settings
from hand_service.config.profile import Profile, load_profile
from hand_service.errors import UserError

DEFAULT_PROFILES = {"serial": "serial-v1.yaml", "slcan": "can-v1-slcan.yaml",
                    "virtual": "can-v1-virtual.yaml"}
CAN_DEFAULT_PROFILE = "can-v1.yaml"


def parse_can(spec: str) -> tuple[str, str]:
    """`--can INTERFACE:CHANNEL` (slcan:/dev/ttyACM0, virtual:bench, socketcan:can0)."""
    interface, sep, channel = spec.partition(":")
    if not sep or not interface or not channel:
        raise UserError(f"--can must be INTERFACE:CHANNEL (slcan:/dev/ttyACM0, virtual:NAME), not {spec!r}")
    if interface not in can.interfaces.VALID_INTERFACES:
        raise UserError(f"--can {spec}: python-can has no interface {interface!r}")
    return interface, channel


def profile_for(port: str | None, can_spec: str | None, path: str | None) -> tuple[Profile, str | None]:
    """The profile (given, or the shipped one for the link) and the CAN interface, if any."""
    if (port is None) == (can_spec is None):
        raise UserError("give a serial PORT, or --can INTERFACE:CHANNEL for a can-v1 board (not both)")
    interface = parse_can(can_spec)[0] if can_spec is not None else None
    default = DEFAULT_PROFILES.get(interface or "serial", CAN_DEFAULT_PROFILE)
    profile = load_profile(path or default)
    kind = profile.transport["kind"]
    if kind != ("can" if can_spec else "serial"):
        wanted = "a can profile (can-v1*.yaml)" if can_spec else "a serial profile (serial-v1.yaml)"
        raise UserError(f"{profile.path}: transport {kind}; this link needs {wanted}")
    return profile, interface


def settings_for(profile: Profile, window_s: float, pressure_kpa: float, latency_ms: float) -> Settings:
    if not math.isfinite(pressure_kpa) or pressure_kpa <= 0:
        raise UserError(f"--pressure-kpa must be a positive number of kPa, not {pressure_kpa:g}")
    highest = min(f.pressure_max_kpa for f in profile.fingers)
    if pressure_kpa > highest:
        raise UserError(f"--pressure-kpa {pressure_kpa:g} is above the lowest finger limit in "
                        f"{profile.path} ({highest:g} kPa)")
    if not math.isfinite(latency_ms) or latency_ms < 0:
        raise UserError(f"--latency-ms must be 0 or more, not {latency_ms:g}")
    safety, transport = profile.safety, profile.transport
    rate_hz = profile.control.rate_hz
    return Settings(protocol_version=profile.protocol_version, n_fingers=len(profile.fingers),
                    rate_hz=rate_hz,
                    watchdog_ms=float(safety["firmware_watchdog_ms"]),
                    handshake_timeout_ms=float(transport["handshake_timeout_ms"]),
                    stale_ms=1e3 * safety["stale_sensor_ticks"] / rate_hz,
                    loss_max_percent=float(safety["sample_loss_max_percent"]),
                    clock_drift_max_ppm=float(safety["clock_drift_max_ppm"]),
                    window_s=window_s, pressure_kpa=pressure_kpa, latency_ms=latency_ms,
                    pressure_measured=bool(safety["pressure_measured"]),
                    host_stall_max_ms=float(safety["host_stall_max_ms"]),
                    fingers=tuple(FingerSense.of(f) for f in profile.fingers))


def open_link(profile: Profile, port: str | None, can_spec: str | None) -> BoardLink:
    settings: dict[str, Any] = profile.transport
    n = len(profile.fingers)
    if can_spec is None:
        assert port is not None
        try:
            return SerialBoardLink(port, settings["baudrate_bps"], n)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise UserError(f"cannot open serial port {port}: {exc}") from None
    interface, channel = parse_can(can_spec)
    arguments: dict[str, Any] = {"interface": interface, "channel": channel}
    if "bitrate_bps" in settings and interface != "virtual":
        arguments["bitrate"] = settings["bitrate_bps"]
    if interface == "slcan":
        arguments.update(tty_baudrate=settings.get("tty_baudrate_bps", 115200), sleep_after_open=0)
    try:
        return CanBoardLink(arguments, settings["dbc"], n)
    except (can.CanError, OSError, ValueError, serial.SerialException) as exc:
        raise UserError(f"cannot open CAN {interface}:{channel}: {exc}") from None
