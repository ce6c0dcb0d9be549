"""The recording as diagnose reads it: its time base and what its command holds."""
