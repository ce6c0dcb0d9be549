"""A model in the wrong units, told in one line before any fit: a finger that rings far
faster than the recording samples (its simulation would crawl at its time scale), or one
that the recorded command drives to angles no finger has."""

from __future__ import annotations

import math

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.errors import UserError
from rtcore.sim import SimFinger

RINGING_LIMIT = 1000.0  # the model's ringing frequency, at most this many times the sample rate
ANGLE_LIMIT_DEG = 1e6  # the recording reader's bound on an angle (hand_service/recording.py)


def check_scales(model: FingerModel, finger: SimFinger, rate_hz: float) -> None:
    """A model whose finger rings a thousand times faster than the recording samples is
    nothing this recording could show, and its simulation would crawl at its time scale:
    a model in the wrong units, said in one line (an over-damped finger, however stiff,
    moves on its slow time scale and passes)."""
    prbm = finger.prbm
    a, b, k = prbm.inertia_kgm2, prbm.damping_nms_per_rad, prbm.stiffness_nm_per_rad
    zeta = b / (2.0 * math.sqrt(k * a))
    ringing_hz = math.sqrt(k / a) * math.sqrt(max(0.0, 1.0 - zeta * zeta)) / (2.0 * math.pi)
    if zeta < 1.0 and ringing_hz > RINGING_LIMIT * rate_hz:
        raise UserError(f"{model.source}: the model's finger rings at {ringing_hz:.3g} Hz, "
                        f"{ringing_hz / rate_hz:.3g} times the recording's {rate_hz:.3g} Hz: nothing in it "
                        "could show that; are k (N·m/rad) and A (kg·m²) in their units?")


def check_nominal(model: FingerModel, angle_deg: np.ndarray) -> None:
    """The model as given, driven by the recorded command, must give angles a finger could
    have: a model in the wrong units otherwise, said in one line."""
    worst = float(np.max(np.abs(angle_deg))) if np.all(np.isfinite(angle_deg)) else math.inf
    if worst > ANGLE_LIMIT_DEG:
        raise UserError(f"{model.source}: driven by the recorded command, the model's finger reaches "
                        f"{worst:.3g}° (beyond {ANGLE_LIMIT_DEG:g}°): are B (N·m·s/rad), k (N·m/rad) and N "
                        "(N·m/kPa) in their units?")
