"""The board conformance check (`hand-service board-check`): does a valve board speak the
protocol of docs/serial-protocol.md or docs/can-protocol.md, as the host relies on it?

link.py reaches the board over serial-v1 or can-v1 and can also send what a good host
never sends (bad CRCs, wrong finger counts, rubbish); session.py records what comes back
with host timestamps; the checks are grouped by what they look at (handshake.py,
stream.py, valves.py, reboot.py); runner.py runs them in order.
"""
