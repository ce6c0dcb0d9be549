"""The raw public recordings behind the fixtures of rigs.py: where each comes from and how
its input and output columns are read (in the source's own units).

Each loader takes the raw file (as stored in the source repository, named as there) and
returns the input u, the output y and the source's sampling interval (s; None where the
source does not give it). Nothing here imports `hand_service`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.io import loadmat

from tests.diagnose.real.odefit import FloatArray


@dataclass(frozen=True)
class Source:
    repository: str
    path: str
    commit: str
    licence: str
    data: str  # what the file is, and whose
    paper: str  # what to cite


@dataclass(frozen=True)
class Raw:
    u: FloatArray
    y: FloatArray
    dt_s: float | None


def _column(mat: Path, key: str) -> FloatArray:
    return np.asarray(loadmat(str(mat))[key], dtype=float).ravel()


def cascaded_tanks(path: Path) -> Raw:
    """dataBenchmark.csv: uEst (pump voltage, V), yEst (lower tank level, V), Ts = 4 s."""
    rows = path.read_text().splitlines()
    header = [h.strip('"') for h in rows[0].split(",")]
    cols = [line.split(",") for line in rows[1:] if line.strip()]
    u = np.array([float(c[header.index("uEst")]) for c in cols])
    y = np.array([float(c[header.index("yEst")]) for c in cols])
    return Raw(u, y, 4.0)


def pneumatic_friction(path: Path) -> Raw:
    """A friction test of a 3D-printed pneumatic cylinder (whitespace separated): time (ms),
    laser (V), pressure (V), force (V), laser (mm), pressure (bar), force (N). The time column
    is irregular (10 ms nominal): the caller resamples."""
    d = np.loadtxt(path)
    return Raw(d[:, 5], d[:, 4], None)


def pneumatic_friction_time_s(path: Path) -> FloatArray:
    return np.loadtxt(path)[:, 0] * 1e-3


def coupled_drives(path: Path) -> Raw:
    """drive.mat: u2 (PRBS of ±1.5, the drive voltage), z2 (the pulley speed from a pulse
    counter that cannot tell the direction, so |speed|), Ts = 20 ms."""
    return Raw(_column(path, "u2"), _column(path, "z2"), 0.02)


def hydraulic_actuator(path: Path) -> Raw:
    """actuator.mat: u (valve opening), p (oil pressure); the sampling interval is not stored."""
    return Raw(_column(path, "u"), _column(path, "p"), None)


def ball_beam(path: Path) -> Raw:
    """ballbeam.dat: beam angle (rad), ball position (m), Ts = 0.1 s."""
    d = np.loadtxt(path)
    return Raw(d[:, 0], d[:, 1], 0.1)


def hair_dryer(path: Path) -> Raw:
    """dryer.dat: heater voltage (V), outlet air temperature (as a thermocouple voltage), Ts = 0.08 s."""
    d = np.loadtxt(path)
    return Raw(d[:, 0], d[:, 1], 0.08)


def flexible_arm(path: Path) -> Raw:
    """robotArm.mat: reaction torque of the structure (input), acceleration of the flexible
    arm (output); the sampling interval is not stored in this copy."""
    d = np.asarray(loadmat(str(path))["robotArm"], dtype=float)
    return Raw(d[:, 0], d[:, 1], None)


def glass_furnace(path: Path) -> Raw:
    """glassfurnace.mat: column 0 the sample index, 1-3 the three inputs (two heating, one
    cooling), 4-9 six temperatures (all normalised). Here the first heating input and the
    first temperature; the other two inputs are left out on purpose."""
    d = np.asarray(loadmat(str(path))["glassfurnace"], dtype=float)
    return Raw(d[:, 1], d[:, 4], None)


LOADERS: dict[str, Callable[[Path], Raw]] = {
    "cascaded_tanks": cascaded_tanks,
    "pneumatic_friction_circle": pneumatic_friction,
    "pneumatic_friction_kidney": pneumatic_friction,
    "coupled_drives": coupled_drives,
    "hydraulic_actuator": hydraulic_actuator,
    "ball_beam": ball_beam,
    "hair_dryer": hair_dryer,
    "flexible_arm": flexible_arm,
    "glass_furnace": glass_furnace,
}

_ZILLEN = dict(repository="github.com/EvaZillen/3D-printed-pneumatic-actuator",
               commit="6e0bcb4633bd53b2a8544cdbd497c4c06539afc7",
               licence="CC0-1.0 (the repository's LICENSE)",
               paper="E. Zillen, H. Vallery, G. Smit, MSc thesis on 3D-printed pneumatic "
                     "actuators, TU Delft Biomechanical Design, 2021 (the repository)")
_DAISY = ("DaISy, Database for the Identification of Systems (B. De Moor, ed., KU Leuven "
          "ESAT-SISTA), free for identification research; cite De Moor et al., DaISy")
_RGP_LICENCE = "repository BSD-3-Clause (Copyright (c) 2015-2016, Zhenwen Dai); "
_FARNN_LICENCE = "repository MIT (Copyright (c) 2016, Olalekan P. Ogunmolu); "
_RGP = dict(repository="github.com/zhenwendai/RGP",
            commit="be679607d3457a1038a2fe39b36b816ea380ea39")
_FARNN = dict(repository="github.com/lakehanne/FARNN",
              commit="3dac80fd71d3c60a7372cedcf5d51b89ba32b2f4")

SOURCES: dict[str, Source] = {
    "cascaded_tanks": Source(
        repository="github.com/forgi86/sysid-neural-structures-fitting",
        path="examples/CTS_example/data/dataBenchmark.csv",
        commit="886c969c03e86422b8a81d9e826b5745a4934bb0",
        licence="repository MIT (Copyright (c) 2019 Marco Forgione); the data are the benchmark's "
                "(nonlinearbenchmark.org), "
                "published free for identification research, cite Schoukens et al. 2016",
        data="Cascaded tanks benchmark, estimation record (uEst, yEst)",
        paper="M. Schoukens, P. Mattsson, T. Wigren, J.-P. Noël, 'Cascaded tanks benchmark "
              "combining soft and hard nonlinearities', Workshop on Nonlinear System "
              "Identification Benchmarks, 2016"),
    "pneumatic_friction_circle": Source(
        path="results_pneumatic-actuator/data/friction/Circle_2bar.csv",
        data="friction test of a 3D-printed pneumatic cylinder, circular bore (O-ring), 2 bar",
        **_ZILLEN),
    "pneumatic_friction_kidney": Source(
        path="results_pneumatic-actuator/data/friction/Kidney_4bar.csv",
        data="friction test of a 3D-printed pneumatic cylinder, kidney-shaped bore, 4 bar",
        **_ZILLEN),
    "coupled_drives": Source(
        path="datasets/system_identification/drive.mat",
        licence=_RGP_LICENCE + "the data are the CE8 coupled electric drives "
                "benchmark's, published free for identification research, cite Wigren & "
                "Schoukens 2017",
        data="Coupled electric drives (CE8), PRBS record of amplitude 1.5 (u2, z2)",
        paper="T. Wigren, M. Schoukens, 'Coupled electric drives data set and reference "
              "models', Uppsala University technical report 2017-024",
        **_RGP),
    "hydraulic_actuator": Source(
        path="datasets/system_identification/actuator.mat",
        licence=_RGP_LICENCE + "the data are Linköping University's (Sjöberg et al.), "
                "distributed with identification toolboxes for research; cite Sjöberg et al. 1995",
        data="Hydraulic actuator of a robot arm: valve opening u, oil pressure p",
        paper="J. Sjöberg et al., 'Nonlinear black-box modeling in system identification: a "
              "unified overview', Automatica 31(12), 1995",
        **_RGP),
    "ball_beam": Source(
        path="datasets/system_identification/ballbeam.dat",
        licence=_RGP_LICENCE + _DAISY,
        data="Ball and beam practicum (ESAT-SISTA): beam angle, ball position",
        paper="DaISy, the ball-and-beam data set",
        **_RGP),
    "hair_dryer": Source(
        path="datasets/system_identification/dryer.dat",
        licence=_RGP_LICENCE + _DAISY,
        data="Laboratory hair dryer (Feedback Process Trainer PT326): heater voltage, air temperature",
        paper="L. Ljung, System Identification, Theory for the User, 1987 (the dryer example); "
              "DaISy, the dryer data set",
        **_RGP),
    "flexible_arm": Source(
        path="data/robotArm.mat",
        licence=_FARNN_LICENCE + _DAISY,
        data="Flexible robot arm on an electric motor: reaction torque, arm acceleration",
        paper="DaISy, the flexible robot arm data set",
        **_FARNN),
    "glass_furnace": Source(
        path="data/glassfurnace.mat",
        licence=_FARNN_LICENCE + _DAISY,
        data="Glass furnace (Philips): 3 inputs (2 heating, 1 cooling), 6 temperatures",
        paper="DaISy, the glass furnace data set",
        **_FARNN),
}
