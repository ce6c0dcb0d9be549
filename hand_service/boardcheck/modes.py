"""How `board-check` may reboot the board, apart from the checks (which need python-can and
cantools): the command line lists them without loading the bus libraries."""

REBOOT_MODES = ("debug", "manual", "skip")  # its debug port (test images), by hand, or not at all
