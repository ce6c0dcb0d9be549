"""A recording file diagnosed as `hand-service diagnose` reads it, and its report run through
the sentence checks (hand_service/diagnose/report/sentence_checks.py): what the fixtures'
tests share, so that each fixture is diagnosed once for its verdict and its sentences."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

from hand_service.commands.diagnose import print_summary
from hand_service.config.profile import load_model
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.recording.timebase import regular_grid
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.diagnose.report.html import evidence_rows
from hand_service.diagnose.report.sentence_checks import evidence_row_failures, facts_of, failures
from hand_service.recording import read_recording


def diagnosed(recording: Path, model: Path, input_hold: str = "zoh") -> Diagnosis:
    rec = read_recording(recording, None)
    grid = regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, recording)
    return diagnose(load_model(model, None), grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz,
                    missing=grid.missing, input_hold=input_hold)


def report_failures(d: Diagnosis) -> list[str]:
    """Every printed sentence (the summary, the notes, the partial effects' evidence, the
    evidence table's rows) that the checks find false of the recording."""
    facts = facts_of(d)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        print_summary(d, screen=False)
    texts = out.getvalue().splitlines() + d.notes + [e.evidence for e in d.partial_effects]
    wrong = [f"{text[:80]}: {f}" for text in texts for f in failures(text, facts)]
    return wrong + evidence_row_failures(d, evidence_rows(d))
