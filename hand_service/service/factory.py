"""A supervisor for a profile and a transport, as its command surface (surface.TickLoop):
how the wiring (app/daemon.py) and the benchmark make one without naming its class."""

from __future__ import annotations

from hand_service.config.profile import Profile
from hand_service.service.recorder import Recorder
from hand_service.service.supervisor import Supervisor
from hand_service.service.surface import TickLoop
from hand_service.transports import Transport


def supervisor(profile: Profile, transport: Transport, recorder: Recorder | None = None,
               spin_us: float = 0.0) -> TickLoop:
    """The supervisor; its tick path (service/tick_path.py) is chosen here, once, from the
    transport. `spin_us`: wake this early and spin to each deadline."""
    return Supervisor(profile, transport, recorder, spin_us=spin_us)
