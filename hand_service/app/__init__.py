"""The wiring above the service, the control API and the view: `hand-service run`."""
