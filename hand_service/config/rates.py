"""The control rates the supervisor supports: one definition for the profile schema
(control.rate_hz), `run --rate` and `bench --rate`. No imports, so a command's --help
can quote it and stay instant."""

RATE_MIN_HZ = 10.0
RATE_MAX_HZ = 1000.0
