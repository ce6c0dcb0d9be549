"""The transport kinds a profile may name (`transport: {kind: sim | can | serial, ...}`).

One table, `KINDS`, as python-can keeps its backends: each kind's class by module and
name (imported only when a transport is built, by hand_service.transports), its profile
keys, an optional check across those keys, and the pressure commands its wire carries.
The profile reads this table; nothing writes into it, and no bus library is loaded to
validate a profile.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

from hand_service.config.schema import Key, Section, fail
from hand_service.config.textfile import lookup, printable
from hand_service.errors import UserError

# python-can's own backend registry (its names only: no backend is loaded).
CAN_INTERFACES = tuple(sorted(can.interfaces.VALID_INTERFACES))
SLCAN_BITRATES_BPS = (10_000, 20_000, 50_000, 83_300, 100_000, 125_000, 250_000, 500_000, 750_000,
                      1_000_000)
RAW_LOG_SUFFIXES = (".asc", ".blf", ".log", ".csv", ".trc")

COMMON_KEYS = (
    Key("handshake_timeout_ms", "open() waits this long for the firmware's version", "float", "ms",
        1000.0, 10.0, 60000.0),
    Key("reconnect_backoff_min_ms", "first wait before reconnecting; doubles after each failure",
        "float", "ms", 50.0, 1.0, 60000.0),
    Key("reconnect_backoff_max_ms", "longest wait between reconnection attempts", "float", "ms",
        2000.0, 1.0, 600000.0),
    Key("sensor_min_mv", "lowest reading the board's ADC can give; below is out of range", "float",
        "mV", 0.0, -100000.0, 100000.0),
    Key("sensor_max_mv", "highest reading the board's ADC can give; above is out of range", "float",
        "mV", 5000.0, -100000.0, 100000.0),
    Key("stuck_samples", "identical readings in a row that count as a stuck sensor (0: off)", "int",
        "samples", 25, 0, 100000),
)

CAN_SECTION = Section(
    "Transport: can", "`transport: {kind: can}` — a CAN valve board through python-can, frames "
    "defined by a DBC and encoded by cantools.", (
        Key("kind", "transport kind", "choice", default="can", choices=("can",)),
        Key("interface", "python-can interface", "choice", choices=CAN_INTERFACES),
        Key("channel", "python-can channel: the virtual bus's name, the SLCAN adapter's serial "
            "port, or a SocketCAN device", "str"),
        Key("bitrate_bps", "CAN bit rate", "int", "bit/s", 500_000, 10_000, 1_000_000),
        Key("dbc", "the DBC defining the frames, relative to the profile", "str"),
        Key("tty_baudrate_bps", "SLCAN only: the adapter's serial line rate", "int", "bit/s",
            115_200, 1200, 12_000_000),
        Key("raw_log", "write every frame in and out to this python-can log (.asc, .blf, ...); "
            "empty: none", "str", default=""),
        *COMMON_KEYS,
    ))

SERIAL_SECTION = Section(
    "Transport: serial", "`transport: {kind: serial}` — a valve board on a serial port (pyserial), "
    "serial-v1 framing (docs/serial-protocol.md).", (
        Key("kind", "transport kind", "choice", default="serial", choices=("serial",)),
        Key("port", "serial device (e.g. /dev/ttyACM0)", "str"),
        Key("baudrate_bps", "line rate (USB CDC ports ignore it)", "int", "bit/s", 921_600, 1200,
            12_000_000),
        *COMMON_KEYS,
    ))


def check_common(values: dict[str, Any], source: Path, block: Any) -> None:
    if values["reconnect_backoff_min_ms"] > values["reconnect_backoff_max_ms"]:
        raise fail(source, block, "reconnect_backoff_min_ms",
                   "transport.reconnect_backoff_min_ms must not exceed reconnect_backoff_max_ms")
    if values["sensor_min_mv"] >= values["sensor_max_mv"]:
        raise fail(source, block, "sensor_min_mv", "transport.sensor_min_mv must be below sensor_max_mv")


def check_can(values: dict[str, Any], source: Path, block: Any) -> None:
    """Cross-key checks; resolves the DBC (and the raw log) next to the profile."""
    check_common(values, source, block)
    if values["interface"] == "slcan" and values["bitrate_bps"] not in SLCAN_BITRATES_BPS:
        raise fail(source, block, "bitrate_bps",
                   f"transport.bitrate_bps = {values['bitrate_bps']} is not an SLCAN rate "
                   f"({', '.join(str(b) for b in SLCAN_BITRATES_BPS)})")
    dbc = Path(values["dbc"])
    dbc = dbc if dbc.is_absolute() else source.parent / dbc
    try:
        kind = lookup(dbc)
    except UserError as exc:  # a name the system cannot look up (too long, say)
        raise fail(source, block, "dbc", f"transport.dbc: {exc}") from None
    if kind == "other":  # never a FIFO or a device: reading one may never end
        raise fail(source, block, "dbc", f"transport.dbc: {printable(str(dbc))} is not a regular file")
    from hand_service.wire.can_codec import load_dbc

    try:
        load_dbc(dbc)
    except UserError as exc:
        raise fail(source, block, "dbc", f"transport.dbc: {exc}") from None
    values["dbc"] = str(dbc.resolve())
    log = values["raw_log"]
    if log and Path(log).suffix.lower() not in RAW_LOG_SUFFIXES:
        raise fail(source, block, "raw_log", f"transport.raw_log must end in one of "
                   f"{', '.join(RAW_LOG_SUFFIXES)}, not {Path(log).suffix or 'nothing'!r}")


def can_command_range(values: dict[str, Any]) -> tuple[float, float, str]:
    """The pressure commands the DBC's ValveCommand carries (kPa); serial-v1 carries any f32."""
    from hand_service.wire.can_codec import load_dbc, signal_range

    dbc = load_dbc(values["dbc"])
    low, high = signal_range(dbc.get_message_by_name("ValveCommand").get_signal_by_name("pressure_cmd_kpa"))
    return low, high, f"ValveCommand.pressure_cmd_kpa in {values['dbc']}"


SIM_SECTION = Section("Transport: sim", "`transport: {kind: sim}` — the in-process "
                      "simulated hand; no hardware, no bus.", (
    Key("kind", "transport kind", "choice", default="sim", choices=("sim",)),
))

Check = Callable[[dict[str, Any], Path, Any], None]
CommandRange = Callable[[dict[str, Any]], tuple[float, float, str]]


@dataclass(frozen=True)
class TransportKind:
    """One kind of transport: where its class lives and what a profile says about it.

    `check(values, source, block)` raises a UserError naming the line when keys disagree;
    `command_range(values)` gives (low kPa, high kPa, what carries them), which every
    finger's pressure limits must lie within.
    """

    module: str
    class_name: str
    section: Section
    check: Check | None = None
    command_range: CommandRange | None = None


KINDS: dict[str, TransportKind] = {
    "sim": TransportKind("hand_service.transports.sim", "SimTransport", SIM_SECTION),
    "can": TransportKind("hand_service.transports.can_transport", "CanTransport", CAN_SECTION,
                         check_can, can_command_range),
    "serial": TransportKind("hand_service.transports.serial_transport", "SerialTransport",
                            SERIAL_SECTION, check_common),
}
