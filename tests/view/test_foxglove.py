"""`run --foxglove`: a Foxglove WebSocket client gets every channel of the MCAP export, with
its schema, and every recorded row, live.

The client speaks the foxglove.websocket.v1 protocol (serverInfo, advertise, subscribe,
binary MessageData) and offers both of its names: foxglove-sdk's server accepts only the
newer one, foxglove.sdk.v1, the same protocol renamed (docs/view.md)."""

from __future__ import annotations

import asyncio
import json
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from hand_service.export.mcap_log import channel_specs
from hand_service.export.table import read_table
from tests.service.process import wait_for

websockets = pytest.importorskip("websockets")
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]  # the protocol's old name and new
MESSAGE_DATA = 0x01  # server -> client binary opcode: subscription id, log time, payload
LISTEN_S = 2.0
RATE_HZ = 100.0


async def _listen(url: str) -> tuple[list[dict], dict[str, list[dict]]]:
    """The advertised channels and, per topic, the messages of LISTEN_S after subscribing."""
    channels: dict[int, dict] = {}
    received: dict[str, list[dict]] = {}
    async with websockets.connect(url, subprotocols=SUBPROTOCOLS, max_size=None) as ws:
        assert ws.subprotocol in SUBPROTOCOLS

        async def advertised() -> None:
            while len(channels) < 6:
                message = await ws.recv()
                if isinstance(message, str):
                    data = json.loads(message)
                    if data["op"] == "advertise":
                        channels.update({c["id"]: c for c in data["channels"]})

        await asyncio.wait_for(advertised(), 30.0)
        topics = {c["id"]: c["topic"] for c in channels.values()}
        subs = [{"id": n, "channelId": cid} for n, cid in enumerate(topics)]
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
        by_sub = {s["id"]: topics[s["channelId"]] for s in subs}
        end = asyncio.get_running_loop().time() + LISTEN_S
        while (left := end - asyncio.get_running_loop().time()) > 0:
            try:
                message = await asyncio.wait_for(ws.recv(), left)
            except asyncio.TimeoutError:
                break
            if isinstance(message, bytes) and message[0] == MESSAGE_DATA:
                sub_id, _log_ns = struct.unpack_from("<IQ", message, 1)
                received.setdefault(by_sub[sub_id], []).append(json.loads(message[13:]))
    return list(channels.values()), received


def test_a_client_gets_every_channel_of_the_mcap_export(tmp_path: Path) -> None:
    record = tmp_path / "run.csv"
    argv = [sys.executable, "-m", "hand_service.cli", "run", "--no-realtime", "--socket", str(tmp_path / "s"),
            "--record", str(record), "--foxglove", "0", "--duration", "120", "--status", "off"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        found: list[str] = []

        def url() -> str | None:
            line = proc.stdout.readline()  # type: ignore[union-attr]
            match = re.search(r"foxglove: (ws://127\.0\.0\.1:\d+)", line)
            if match:
                found.append(match.group(1))
            assert line or proc.poll() is None, "the daemon ended before the Foxglove server started"
            return found[0] if found else None

        address = wait_for(url, 60.0, "the Foxglove server's address")
        channels, received = asyncio.run(_listen(address))
        proc.terminate()  # vents, closes the recording, ends the Foxglove server
        assert proc.wait(60) == 0
    finally:
        proc.kill()
        proc.wait()
    specs = {s.topic: s for s in channel_specs(read_table(record))}
    assert sorted(c["topic"] for c in channels) == sorted(specs)
    for channel in channels:
        spec = specs[channel["topic"]]
        assert channel["encoding"] == "json" and channel["schemaEncoding"] == "jsonschema"
        assert channel["schemaName"] == spec.schema_name
        live, exported = json.loads(channel["schema"]), json.loads(spec.schema_json)
        assert live["properties"].keys() == exported["properties"].keys()
        for key, field in live["properties"].items():  # a column of whole numbers exports as integer
            assert field["unit"] == exported["properties"][key]["unit"], key
    assert set(received) == set(specs)
    for topic, messages in received.items():
        assert set(messages[0]) == set(specs[topic].fields), topic
    times = [m["t"] for m in received["/hand"]]
    t_s = read_table(record).columns["t"]
    recorded = [round(float(t), 4) for t in t_s if times[0] <= t <= times[-1]]
    assert len(times) > LISTEN_S * RATE_HZ / 2 and times == recorded  # every recorded row, in order
