"""Every sentence `diagnose` prints, checked against the recording before it is printed.

Each check reads a claim out of a sentence and tests it against facts measured from the
recording and the refitted finger:

- a delay ("starts to move about X ms later") against the response's onset after the
  command's steps (recording/response_onset.py);
- a resonance only where the refitted finger rings (ζ < 0.7) and the rate can show it
  (below a quarter of the rate); advice for content near a frequency only below that too;
- a period ("repeats at f Hz") only where the command repeats (its autocorrelation peaks
  there);
- no uncertainty (±) beside "held near", and "held near" only where no held parameter was
  refitted far from the nominal;
- no value printed with an uncertainty larger than itself without saying it is unknown;
- one subject, one verb ("cubic_stiffness reduces"); time windows printed as "a to b", no
  "-0.00";
- "so it is named" or "so they are named" only where the verdict names an effect (a step of
  the search says "kept", and "the checks that follow decide what is named").

The summary and the HTML report print only what passes (`screened`); the tests run every
fixture's sentences through `failures` unscreened, so that what the engine writes is held to
the same checks.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from hand_service.diagnose.recording.excitation import SHOWN_BELOW, own_frequency_hz, period_s
from hand_service.diagnose.recording.response_onset import delay_seen, onset_delay_s
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.diagnose.report.verdict import HELD_NEAR

NUMBER = r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?"


@dataclass(frozen=True)
class Facts:
    """What the sentences are checked against, measured from the recording and the refit."""

    rate_hz: float
    onset_s: float | None  # the response's onset after the command's steps (None: no clear step)
    rings: bool  # the refitted finger is under-damped
    own_hz: float  # its resonance (ringing) or corner frequency
    period_s: float | None  # the command's period, where it repeats
    n_fit: int
    held_ratio: dict[str, float] = field(default_factory=dict)  # refit/nominal of the plain parameters
    named: tuple[str, ...] = ()  # the effects the verdict names


def facts_of(d: Diagnosis) -> Facts:
    p = d.problem
    source = d.refit
    k, b = source.value("stiffness_nm_per_rad"), source.value("damping_nms_per_rad")
    own_hz, rings = own_frequency_hz(k, b, p.base.prbm.inertia_kgm2)
    ratios = {}
    for label in ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa"):
        nominal = float(getattr(d.model, label))
        if nominal != 0.0 and label in [q.label for q in source.params]:
            ratios[label] = source.value(label) / nominal
    return Facts(p.rate_hz, onset_delay_s(p.pressure_kpa, p.measured_deg, p.rate_hz), rings, own_hz,
                 period_s(p.pressure_kpa, p.rate_hz), p.n_fit, ratios, tuple(e.name for e in d.effects))


def _delay(text: str, f: Facts) -> list[str]:
    out = []
    for m in re.finditer(rf"starts to move about ({NUMBER}) ms later", text):
        if not delay_seen(float(m.group(1)) * 1e-3, f.onset_s, f.rate_hz):
            out.append(f"a delay of {m.group(1)} ms, but the recorded response starts "
                       f"{1e3 * (f.onset_s or 0.0):.0f} ms after the command's steps")
    return out


def _resonance(text: str, f: Facts) -> list[str]:
    out = []
    for m in re.finditer(rf"resonance \(({NUMBER}) Hz\)", text):
        hz = float(m.group(1))
        if not f.rings:
            out.append(f"a resonance at {hz:g} Hz, but the refitted finger does not ring")
        elif hz >= SHOWN_BELOW * f.rate_hz:
            out.append(f"a resonance at {hz:g} Hz, beyond what {f.rate_hz:g} Hz sampling shows")
    for m in re.finditer(rf"content near ({NUMBER}) Hz", text):
        hz = float(m.group(1))
        if hz >= SHOWN_BELOW * f.rate_hz:
            out.append(f"advice for content near {hz:g} Hz, beyond what {f.rate_hz:g} Hz sampling shows")
    return out


def _period(text: str, f: Facts) -> list[str]:
    out = []
    for m in re.finditer(rf"repeats at ({NUMBER}) Hz", text):
        hz = float(m.group(1))
        if f.period_s is None or abs(f.period_s * hz - 1.0) > 0.25:
            out.append(f"a period of {1 / hz:.3g} s, but the command does not repeat at it")
    return out


def _held_near(text: str, f: Facts) -> list[str]:
    if "held near" not in text and "near the nominal" not in text:
        return []
    out = []
    if re.search(rf"±\s?{NUMBER}", re.sub(rf"a prior of ±{NUMBER} %", "", text)):
        out.append("an uncertainty beside 'held near'")
    near = re.search(r"holds ([a-z_, ]+) near the nominal", text)
    for label in (near.group(1).split(", ") if near else []):
        r = f.held_ratio.get(label.strip())
        if r is not None and not 1.0 / HELD_NEAR <= r <= HELD_NEAR:
            out.append(f"{label} said held near the nominal, refitted to {r:.3g} times it")
    return out


def _unknown(text: str, f: Facts) -> list[str]:
    out = []
    for m in re.finditer(rf"({NUMBER})(?: [^\s±]+)?\s+±\s?({NUMBER})", text):
        value, std = float(m.group(1)), float(m.group(2))
        tail = text[m.end(): m.end() + 60]
        if std > abs(value) and "unknown" not in tail:
            out.append(f"{m.group(0).strip()} printed without saying the value is unknown")
    return out


def _grammar(text: str, f: Facts) -> list[str]:
    out = []
    if m := re.search(r"(?:^|warning: )([a-z_]+) (also )?(reduce|fit|explain) ", text):
        out.append(f"'{m.group(1)} {m.group(2) or ''}{m.group(3)}': one subject, a plural verb")
    if text.startswith("windows") and re.search(r"-0\.00|\d-[-\d]", text):
        out.append("a time window printed as 'a-b'")
    return out


def _named(text: str, f: Facts) -> list[str]:
    if re.search(r"\bso (?:it is|they are) named\b", text) and not f.named:
        return ["that effects are named, but the verdict names none"]
    return []


CHECKS = (_delay, _resonance, _period, _held_near, _unknown, _grammar, _named)


def failures(text: str, facts: Facts) -> list[str]:
    """What in `text` is not true of the recording (empty: it may be printed)."""
    return [failure for check in CHECKS for failure in check(text, facts)]


def screened(lines: list[str], facts: Facts) -> list[str]:
    """The lines as printed: a line that fails a check is replaced by what it got wrong."""
    out = []
    for line in lines:
        wrong = failures(line, facts)
        out.append(line if not wrong else f"(a sentence withheld: it said {'; '.join(wrong)})")
    return out


def evidence_row_failures(d: Diagnosis, rows: list[list[str]]) -> list[str]:
    """Rows of the evidence table with ΔBIC far below −ln n (a fit worse than the model it adds to)."""
    floor = -math.log(max(d.problem.n_fit, 2))
    return [f"{row[0]}: ΔBIC {row[2]}" for row in rows if float(row[2]) < floor]
