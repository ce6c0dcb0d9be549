"""The force estimate's span: the lever arm that makes a known load read as itself."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.identification.span import MIN_LOAD_N, apply_span, span_lever


def _sweeps(scale: float, load_n: float) -> tuple[np.ndarray, np.ndarray]:
    """An unloaded sweep's estimate (an offset and a loop that averages out over whole
    periods) and the loaded one, reading the load times scale on top of it."""
    phase = np.linspace(0.0, 4.0 * np.pi, 800, endpoint=False)
    unloaded = 0.03 + 0.1 * np.sign(np.cos(phase))
    return unloaded, unloaded + scale * load_n


@pytest.mark.parametrize("scale", [1.14, 0.95, 1.05 * 1.14])
def test_the_span_scales_the_lever_so_the_load_reads_as_itself(scale: float) -> None:
    unloaded, loaded = _sweeps(scale, 0.6)
    span = span_lever("index", 0.05, unloaded, loaded, 0.6)
    assert span.scale == pytest.approx(scale, rel=1e-9)
    assert span.lever_after_m == pytest.approx(0.05 * scale, rel=1e-9)
    # the estimate is a torque over the lever: over r·s the load reads as itself
    assert (loaded.mean() - unloaded.mean()) * 0.05 / span.lever_after_m == pytest.approx(0.6, rel=1e-9)


def test_the_span_writes_only_its_fingers_lever() -> None:
    truth = load_profile(None)
    r_m = truth.finger("index").model.lever_arm_m
    unloaded, loaded = _sweeps(1.1, 0.5)
    spanned = apply_span(truth, span_lever("index", r_m, unloaded, loaded, 0.5))
    assert spanned.finger("index").model.lever_arm_m == pytest.approx(1.1 * r_m, rel=1e-9)
    assert spanned.finger("thumb").model == truth.finger("thumb").model


def test_the_span_refuses_what_it_cannot_read() -> None:
    unloaded, loaded = _sweeps(1.1, 0.5)
    with pytest.raises(ValueError, match="too small"):
        span_lever("index", 0.05, unloaded, loaded, 0.5 * MIN_LOAD_N)
    with pytest.raises(ValueError, match="outside"):
        span_lever("index", 0.05, unloaded, unloaded + 0.1, 0.5)  # read a fifth of the load
    with pytest.raises(ValueError, match="non-finite"):
        span_lever("index", 0.05, np.full(10, np.nan), loaded, 0.5)
    with pytest.raises(ValueError, match="both sweeps"):
        span_lever("index", 0.05, np.array([]), loaded, 0.5)
