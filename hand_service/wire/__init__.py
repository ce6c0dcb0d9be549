"""The wire protocols between the host and the valve board.

`messages` holds the protocol as plain data, with no I/O (as moteus keeps its frames
apart from the bus library). `can_codec` turns messages into CAN frames and back
with cantools and the profile's DBC; `framing` and `serial_codec` do the same for the
serial-v1 byte stream. The host transports and the mock firmware share these codecs,
so the two ends of every link are the same code read from both sides.
"""
