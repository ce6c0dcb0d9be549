"""hand_service: the supervisor, simulator and model tools for pneumatic soft hands."""

__version__ = "0.1.0"
