"""Physics outside the library that a named effect may stand in for: contacts,
rate-independent loops, material hysteresis."""
