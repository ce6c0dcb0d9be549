"""The valve-board firmware for tests and the bench: the C board (board/core) behind a real
wire protocol, with its simulated hand. This package holds no firmware logic, only how
to run it:

    board.py   the C board in this process (cffi: hand_service.firmware._board), on a port
    ports.py   the firmware's side of the wire: a python-can bus, a pty, an SLCAN adapter
    rig.py     a firmware and the way to reach it, for each of the three tested links
    hold.py    a minimal host that holds a pressure (the tests SIGKILL it)

Run it in its own process with `hand-service mock-firmware`, or, on python-can's
in-process virtual bus, in a thread with `board.run_in_thread`.
"""
