"""Two clients of a Foxglove WebSocket server, written from the protocol's specification
(foxglove/ws-protocol, `foxglove.websocket.v1`) with the `websockets` package. The protocol has
two names: the reading client offers only the old one, `foxglove.websocket.v1` (Foxglove before
the rename, Lichtblick), the stuck one only the new one, `foxglove.sdk.v1`; both report what the
server chose.

- a stuck client: subscribes to every channel, then never reads again (the server must drop
  messages for it rather than hold anything up);
- a reading client: subscribes to every channel and decodes what comes (foxglove.* with
  protobuf from the advertised FileDescriptorSet).

Prints "ready" once both are subscribed, then, when the server closes the connections, one
JSON object: topics advertised, messages received by each client, and the last message of
each foxglove.Grid channel decoded.

Usage: foxglove_client.py ws://127.0.0.1:PORT
"""
import asyncio
import base64
import json
import struct
import sys

import websockets
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

LEGACY = ["foxglove.websocket.v1"]
CURRENT = ["foxglove.sdk.v1"]


async def advertised(ws):
    """Reads text messages until the first advertise; returns its channels."""
    info = None
    while True:
        msg = json.loads(await ws.recv())
        if msg["op"] == "serverInfo":
            info = msg
        elif msg["op"] == "advertise":
            return info, msg["channels"]


def grid_class(channel):
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for fd in fds.file:
        pool.Add(fd)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def unpack_grid(m):
    fields = {f.name: f.offset for f in m.fields}
    data = bytes(m.data)
    n = len(data) // m.cell_stride
    occ = [struct.unpack_from("<b", data, i * m.cell_stride + fields["occupancy"])[0] for i in range(n)]
    return {
        "frame_id": m.frame_id,
        "column_count": m.column_count,
        "cell_size": [m.cell_size.x, m.cell_size.y],
        "origin": [m.pose.position.x, m.pose.position.y],
        "fields": sorted(fields),
        "occupancy": occ,
    }


async def main(url):
    stuck = await websockets.connect(url, subprotocols=CURRENT, max_queue=1,
                                     max_size=None, ping_interval=None)
    _, channels = await advertised(stuck)
    await stuck.send(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": i, "channelId": c["id"]} for i, c in enumerate(channels)]}))
    # From here on the stuck client never reads until the server closes.
    reader = await websockets.connect(url, subprotocols=LEGACY, max_size=None,
                                      ping_interval=None)
    info, channels = await advertised(reader)
    by_sub = {}
    for i, c in enumerate(channels):
        by_sub[i] = c
    await reader.send(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": i, "channelId": c["id"]} for i, c in by_sub.items()]}))
    print("ready", flush=True)
    received, per_topic, last, errors = 0, {}, {}, []
    classes = {}
    try:
        async for msg in reader:
            if isinstance(msg, str):
                text = json.loads(msg)
                if text["op"] == "advertise":
                    # Channels made after the first advertise: subscribe to them too.
                    new = []
                    for c in text["channels"]:
                        if all(c["id"] != d["id"] for d in by_sub.values()):
                            by_sub[len(by_sub)] = c
                            channels.append(c)
                            new.append({"id": len(by_sub) - 1, "channelId": c["id"]})
                    if new:
                        await reader.send(json.dumps({"op": "subscribe", "subscriptions": new}))
                continue
            if msg[0] != 0x01:
                continue
            sub, _log_time = struct.unpack_from("<IQ", msg, 1)
            payload = msg[13:]
            c = by_sub[sub]
            received += 1
            per_topic[c["topic"]] = per_topic.get(c["topic"], 0) + 1
            if c["schemaName"] == "foxglove.Grid":
                cls = classes.get(c["id"]) or classes.setdefault(c["id"], grid_class(c))
                try:
                    last[c["topic"]] = unpack_grid(cls.FromString(payload))
                except Exception as e:  # noqa: BLE001 - reported to the test
                    errors.append(f"{c['topic']}: {e!r}")
    except websockets.ConnectionClosed:
        pass
    # What the stuck client had been sent, now that the server is gone.
    stuck_received = 0
    try:
        while True:
            m = await asyncio.wait_for(stuck.recv(), timeout=5)
            if not isinstance(m, str):
                stuck_received += 1
    except (websockets.ConnectionClosed, asyncio.TimeoutError):
        pass
    print(json.dumps({
        "server": info.get("name") if info else None,
        "subprotocol": reader.subprotocol,
        "stuck_subprotocol": stuck.subprotocol,
        "topics": sorted(c["topic"] for c in channels),
        "schemas": {c["topic"]: [c["schemaName"], c["encoding"]] for c in channels},
        "received": received,
        "per_topic": per_topic,
        "stuck_received": stuck_received,
        "errors": errors,
        "last": last,
    }), flush=True)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1]))
