"""Independent test truth for `hand-service diagnose`.

Everything in this package is written apart from the code under test: nothing here imports
or copies `hand_service.config.effects`, `hand_service.diagnose`, `rtcore` or `csrc`. The plants
integrate their own physical forms (stick-slip friction, posture-dependent gravity, a
stiffening spring that is not cubic, a rate-limited valve, a soft-kneed dead zone, ...) that
differ from the library's, so the battery measures what a lab's recordings would get.

Modules:

- `plant`: the truth fingers (three families) and their integrator.
- `sensor`: offset, drift, white and correlated noise, ADC steps.
- `excitation`: the recordings labs make, open and closed loop.
- `linear`: the exact zero-order-hold linear model and its refit (k, B, N).
- `distinct`: whether a recording can tell the effect from what else a lab allows.
- `calibration`: the effect's strength at a target visibility.
- `cases`: one battery case: truth, concealment, observability.
- `files`: a case on disk (recording, nominal model, truth), for diagnose.
- `scoring`: what diagnose said against the truth.
- `report`: the battery's tables.
- `battery`: the runner (`python -m tests.diagnose.truth.battery --out results.json`).
"""
