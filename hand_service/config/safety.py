"""The safety limits (a profile's `safety:` block): what the supervisor and the bus
transports enforce, validated and documented (docs/profiles.md) from SAFETY_SECTION.
docs/safety.md says which check each key sets and how fast it acts.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hand_service.config.schema import Key, Section, fail

SAFETY_SECTION = Section("Safety", "`safety:` — limits the supervisor enforces; any breach vents.", (
    Key("stale_sensor_ticks", "sensor samples lost in a row (by the firmware's sequence, one per tick) "
        "before a fault", "int", "ticks",
        5, 1, 1000),
    Key("angle_min_deg", "lowest plausible angle", "float", "deg", -60.0, -360.0, 360.0),
    Key("angle_max_deg", "highest plausible angle", "float", "deg", 200.0, -360.0, 360.0),
    Key("overrun_streak", "consecutive deadline misses before a fault", "int", "ticks", 10, 1,
        100000),
    Key("leak_tolerance_kpa", "measured pressure may trail the command by this much", "float",
        "kPa", 30.0, 0.0, None, True),
    Key("leak_ticks", "ticks the measured pressure may stay outside the tolerance", "int",
        "ticks", 50, 1, 100000),
    Key("firmware_watchdog_ms", "the firmware vents when no valid command comes for this long",
        "float", "ms", 100.0, 1.0, 10000.0),
    Key("transport_timeout_ms", "no frame at all (supervisor: no sensor frame) for this long: "
        "transport lost", "float", "ms",
        500.0, 1.0, 60000.0),
    Key("target_angle_min_deg", "lowest angle target the control API accepts", "float", "deg",
        0.0, -360.0, 360.0),
    Key("target_angle_max_deg", "highest angle target the control API accepts", "float", "deg",
        180.0, -360.0, 360.0),
    Key("target_force_min_n", "smallest force target the control API and trajectories accept; "
        "0: a finger only presses. Below 0 allows a finger that an object holds bent to press back "
        "less than its spring would", "float", "N", 0.0, -1000.0, 0.0),
    Key("target_force_max_n", "largest force target the control API and trajectories accept",
        "float", "N", 10.0, 0.0, 1000.0, True),
    Key("sample_age_max_ms", "a sample older than this on the board's clock, or none newer for "
        "this long, is a fault (the host-board offset comes from the fastest samples; at least two "
        "sample periods)", "float", "ms", 100.0, 1.0, 10000.0),
    Key("sample_loss_max_percent", "share of the board's samples that may be lost (dropped, or "
        "failed their CRC) over any 0.5 s", "float", "%", 10.0, 0.0, 100.0, True),
    Key("latency_max_ms", "the link's command -> sensor round trip on the host's clock (the "
        "smallest over any 0.25 s) may be this long: a command out, the board's next sample, the "
        "sample back. Longer is a fault named latency, whatever the board's clock does", "float", "ms",
        50.0, 1.0, 10000.0),
    Key("host_stall_max_ms", "a stall of the host itself (its link reader not run) this long at most "
        "is ridden through: counted, logged, shown in status; the samples it made late or lost are "
        "not the link's. Shorter than firmware_watchdog_ms: the board kept the last command "
        "(docs/safety.md)", "float", "ms", 80.0, 0.0, 10000.0),
    Key("clock_drift_max_ppm", "the board's clock may run this much faster or slower than the "
        "host's", "float", "ppm", 5000.0, 0.0, 1e6, True),
    Key("bus_error_frames_max", "CAN error frames in any second before a fault (bus-off and "
        "error-passive fault at once)", "int", "frames", 10, 0, 100000),
    Key("pressure_measured", "the board measures every chamber's pressure: a NaN (not reported) "
        "is a fault. false: none is measured; the model check runs on the modelled chamber "
        "pressure and the leak check does not run", "bool", default=True),
    Key("model_uncertainty_percent", "how far each of the model's k, B, N and A may be off, "
        "propagated to the predicted angle (docs/safety.md)", "float", "%", 10.0, 0.0, 100.0),
    Key("angle_noise_deg", "the flex sensor's noise on the rig, one standard deviation (the model "
        "check allows five, with what it makes of the pressure noise)", "float", "deg", 0.3, 0.0, 20.0),
    Key("pressure_noise_kpa", "the chamber pressure sensor's noise on the rig, one standard "
        "deviation", "float", "kPa", 0.5, 0.0, 100.0),
    Key("model_margin_deg", "added to the model check's bound beyond the parameters' uncertainty "
        "and the noise: what the model leaves out (hysteresis, a sensor's calibration)", "float",
        "deg", 1.0, 0.0, 90.0, True),
    Key("sensor_drift_max_deg_per_s", "the model check's trend test: the innovation's trend, with "
        "what the prediction and its sensitivities explain taken out (fitted over about 0.5 s, less "
        "three standard errors), may be this steep either way for model_mismatch_ms (docs/safety.md)",
        "float", "deg/s", 2.5, 0.0, 1000.0, True),
    Key("model_mismatch_ms", "the measured angle may stay outside the model's bound this long "
        "before a fault (at least one sample period)", "float", "ms", 100.0, 1.0, 10000.0),
))


def check_safety(safety: dict[str, Any], rate_hz: float, source: str | Path, block: Any) -> None:
    """What the keys' ranges alone cannot say: the angles in order, the force targets, and
    times the checks count in samples that hold whole samples at the control rate."""
    if safety["angle_min_deg"] >= safety["angle_max_deg"]:
        raise fail(source, block, "angle_min_deg", "safety.angle_min_deg must be below safety.angle_max_deg")
    if not (safety["angle_min_deg"] <= safety["target_angle_min_deg"]
            < safety["target_angle_max_deg"] <= safety["angle_max_deg"]):
        raise fail(source, block, "target_angle_min_deg",
                   "safety: the angle targets must lie inside the safe angles, "
                   "angle_min_deg <= target_angle_min_deg < target_angle_max_deg <= angle_max_deg")
    if safety["target_force_min_n"] < -safety["target_force_max_n"]:
        raise fail(source, block, "target_force_min_n",
                   "safety.target_force_min_n must not be below -target_force_max_n")
    if safety["host_stall_max_ms"] >= safety["firmware_watchdog_ms"]:
        raise fail(source, block, "host_stall_max_ms", f"safety.host_stall_max_ms = "
                   f"{safety['host_stall_max_ms']:g} ms must be shorter than firmware_watchdog_ms "
                   f"({safety['firmware_watchdog_ms']:g} ms): a longer stall of the host lets the board vent")
    period_ms = 1e3 / rate_hz
    for key, periods in (("model_mismatch_ms", 1), ("sample_age_max_ms", 2)):
        if safety[key] < periods * period_ms:
            raise fail(source, block, key, f"safety.{key} = {safety[key]:g} ms is shorter than "
                       f"{'one sample period' if periods == 1 else f'{periods} sample periods'} "
                       f"({periods * period_ms:g} ms at control.rate_hz {rate_hz:g})")


__all__ = ["SAFETY_SECTION", "check_safety"]
