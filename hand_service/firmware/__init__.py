"""The mock valve-board firmware: the simulated hand behind a real wire protocol.

Run it in its own process with `hand-service mock-firmware`, or, on python-can's
in-process virtual bus, in a thread with `run_in_thread`.
"""

from hand_service.firmware.mock import MockFirmware, MockThread, run_in_thread

__all__ = ["MockFirmware", "MockThread", "run_in_thread"]
