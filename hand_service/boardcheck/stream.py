"""What the board sends with no command from the host: samples at the profile's rate, with
sequence numbers that count them, and a 10 Hz Status heartbeat on a clock that keeps time.

The board reports whether or not anyone commands it (idle and vented it still sends), so
these checks listen while the host sends nothing.
"""

from __future__ import annotations

import itertools

import numpy as np

from hand_service.boardcheck.link import Received
from hand_service.boardcheck.results import CheckResult, failed, verdict
from hand_service.boardcheck.session import Session, samples, statuses
from hand_service.wire.messages import FirmwareState, SensorReport, sequence_delta

RATE_TOLERANCE = 0.05  # the board's sample rate, as timed by this host over the window
SAMPLES_PER_STATUS = 10  # a Status with every 10th sample: 10 Hz at 100 Hz
HEARTBEAT_TOLERANCE = 0.2


def listen(session: Session) -> list[Received]:
    session.progress(f"listening for {session.settings.window_s:g} s with no command")
    return session.pump(session.settings.window_s)


def rate(session: Session, got: list[Received]) -> CheckResult:
    cfg = session.settings
    name = "report-rate"
    rows = samples(got)
    if len(rows) < 3:
        return failed(name, f"{len(rows)} sample(s) in {cfg.window_s:g} s with no command; the board must "
                      f"report at {cfg.rate_hz:g} Hz whether or not it is commanded")
    from scipy.stats import theilslopes  # here: the mock firmware imports this package

    times = np.array([t for t, _ in rows])
    board_times = np.array([r.board_t_s - r.grace_s for r in got if isinstance(r.message, SensorReport)])
    # the Theil-Sen slope of arrival time against arrival count: a stall of this computer
    # (samples queued, then read at once) is a few outlying points, not the board's rate
    period_s = float(theilslopes(times, np.arange(len(times)))[0])
    measured_hz = 1.0 / period_s if period_s > 0 else float("inf")
    arrival_hz = (len(times) - 1) / (times[-1] - times[0]) if times[-1] > times[0] else float("inf")
    gaps_ms = np.diff(times) * 1e3
    jitter_ms = np.abs(gaps_ms - 1e3 * cfg.period_s)
    # a gap this process made itself (it stalled, the samples waited in the port) is not the board's:
    # the board's gap is at least from reading one sample to when the next could have been read
    board_gaps_ms = np.maximum(0.0, board_times[1:] - times[:-1]) * 1e3
    own_ms = np.array([1e3 * session.stalled_s(a, b) for a, b in itertools.pairwise(times)])
    max_gap_ms = float(board_gaps_ms.max())
    gap_limit_ms = cfg.stale_ms + cfg.latency_ms
    values = {"rate_hz": measured_hz, "arrival_rate_hz": arrival_hz, "expected_hz": cfg.rate_hz,
              "jitter_p50_ms": np.percentile(jitter_ms, 50), "jitter_p99_ms": np.percentile(jitter_ms, 99),
              "max_gap_ms": max_gap_ms, "max_arrival_gap_ms": float(gaps_ms.max()),
              "own_stall_ms": float(own_ms.sum()),
              "max_gap_limit_ms": gap_limit_ms, "samples": len(rows)}
    rate_ok = abs(measured_hz / cfg.rate_hz - 1.0) <= RATE_TOLERANCE
    text = (f"{measured_hz:.2f} Hz (profile {cfg.rate_hz:g} Hz ±{RATE_TOLERANCE:.0%}; samples over the "
            f"window {arrival_hz:.2f} Hz), arrival jitter "
            f"p50 {values['jitter_p50_ms']:.2f} ms p99 {values['jitter_p99_ms']:.2f} ms, longest gap "
            f"{max_gap_ms:.1f} ms (limit {gap_limit_ms:.0f} ms"
            + (f"; this host's own stalls of {own_ms.sum():.0f} ms not counted)" if own_ms.any() else ")"))
    return verdict(name, rate_ok and max_gap_ms <= gap_limit_ms, text, **values)


def sequence(session: Session, got: list[Received]) -> CheckResult:
    """Sample sequence: +1 per sample, never repeated; serial-v1's frame sequence: +1 per frame."""
    cfg = session.settings
    name = "sequence"
    rows = samples(got)
    if len(rows) < 2:
        return failed(name, "too few samples to follow the sequence")
    deltas = [sequence_delta(b.sequence, a.sequence) for (_, a), (_, b) in itertools.pairwise(rows)]
    repeats = sum(1 for d in deltas if d == 0 or d >= 128)
    lost = sum(d - 1 for d in deltas if 1 < d < 128)
    loss_percent = 100.0 * lost / (len(rows) + lost)
    frames = [r.frame_sequence for r in got if r.frame_sequence is not None]
    frame_deltas = [sequence_delta(b, a) for a, b in itertools.pairwise(frames)]
    frame_repeats = sum(1 for d in frame_deltas if d == 0 or d >= 128)
    frame_lost = sum(d - 1 for d in frame_deltas if 1 < d < 128)
    values = {"samples": len(rows), "repeated": repeats, "lost": lost, "loss_percent": loss_percent,
              "frames": len(frames), "frame_sequence_repeated": frame_repeats,
              "frame_sequence_lost": frame_lost,
              "first_sequence": rows[0][1].sequence, "last_sequence": rows[-1][1].sequence}
    frame_text = (f"; frame header sequence: {frame_repeats} repeated, {frame_lost} skipped in {len(frames)} "
                  "frames" if frames else "")
    text = (f"sample sequence {rows[0][1].sequence}..{rows[-1][1].sequence}: {repeats} repeated, {lost} lost "
            f"({loss_percent:.1f} %, limit {cfg.loss_max_percent:g} %){frame_text}")
    if repeats:
        text += " (a sample sequence must go up by one with every sample)"
    if frame_repeats:
        text += " (the frame sequence must go up by one with every frame the board sends)"
    ok = repeats == 0 and frame_repeats == 0 and loss_percent <= cfg.loss_max_percent
    ok = ok and 100.0 * frame_lost / max(1, len(frames) + frame_lost) <= cfg.loss_max_percent
    return verdict(name, ok, text, **values)


def heartbeat(session: Session, got: list[Received]) -> CheckResult:
    """Status with every 10th sample (10 Hz at 100 Hz), an uptime that keeps the host's time,
    a state that is not running."""
    cfg = session.settings
    name = "heartbeat"
    rows = statuses(got)
    heartbeat_hz = cfg.rate_hz / SAMPLES_PER_STATUS
    if len(rows) < 3:
        return failed(name, f"{len(rows)} Status in {cfg.window_s:g} s; the board must send one at "
                      f"{heartbeat_hz:g} Hz (every {SAMPLES_PER_STATUS}th sample)")
    times = np.array([t for t, _ in rows])
    uptimes_ms = np.array([s.uptime_ms for _, s in rows], dtype=np.float64)
    measured_hz = (len(rows) - 1) / (times[-1] - times[0])
    host_ms = (times[-1] - times[0]) * 1e3
    drift_ppm = ((uptimes_ms[-1] - uptimes_ms[0]) / host_ms - 1.0) * 1e6
    # two arrival times, each late by up to the latency allowance, bound what can be measured
    drift_limit_ppm = max(cfg.clock_drift_max_ppm, 2 * cfg.latency_ms / host_ms * 1e6)
    states = sorted({s.state.name.lower() for _, s in rows})
    values = {"rate_hz": measured_hz, "uptime_vs_host_ppm": drift_ppm, "drift_limit_ppm": drift_limit_ppm,
              "states": states, "uptime_ms": int(uptimes_ms[-1])}
    problems = []
    if abs(measured_hz / heartbeat_hz - 1.0) > HEARTBEAT_TOLERANCE:
        problems.append(f"Status at {measured_hz:.1f} Hz, not {heartbeat_hz:g} Hz")
    if np.any(np.diff(uptimes_ms) < 0):
        problems.append("uptime_ms went down with no reboot")
    if abs(drift_ppm) > drift_limit_ppm:
        problems.append(f"uptime_ms runs {drift_ppm:+.0f} ppm from the host's clock (limit "
                        f"{drift_limit_ppm:.0f})")
    if any(s.state == FirmwareState.RUNNING for _, s in rows):
        problems.append("state running with no command for the whole window (the watchdog should have "
                        "vented)")
    text = (f"Status at {measured_hz:.1f} Hz, uptime {drift_ppm:+.0f} ppm against the host's clock, state "
            f"{'/'.join(states)} with no command")
    return verdict(name, not problems, "; ".join([*problems, text]) if problems else text, **values)
