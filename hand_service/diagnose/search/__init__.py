"""Naming missing library effects: the screen, the forward selection and the posture check."""
