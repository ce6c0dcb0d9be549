from __future__ import annotations

import pytest

from rtcore import FingerConfig, Prbm


@pytest.fixture
def index_finger() -> FingerConfig:
    """The index finger of docs/physics.md, with a linear sensor: angle = 0.1 * mV - 5."""
    return FingerConfig(
        Prbm(
            inertia_kgm2=1.617e-4,
            damping_nms_per_rad=0.0031,
            stiffness_nm_per_rad=0.570,
            pressure_gain_nm_per_kpa=8.954e-3,
            lever_arm_m=0.040375,
        ),
        sensor_gain_deg_per_mv=0.1,
        sensor_offset_deg=-5.0,
    )


def mv_for_deg(finger: FingerConfig, angle_deg: float) -> float:
    return (angle_deg - finger.sensor_offset_deg) / finger.sensor_gain_deg_per_mv
