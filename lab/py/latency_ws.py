"""Receives every message of a Foxglove WebSocket server (`foxglove.websocket.v1`, written from
the protocol's specification with the `websockets` package) and logs when each arrived.

Prints "ready" once the server has introduced itself (channels come when first used), subscribes
to every channel advertised, and when the server closes the connection prints one JSON object:
{"messages": [[topic, log_time_ns, received_ns], ...]} where log_time_ns is the message's log
time as the server sent it (the hand-off's stamp) and received_ns the wall clock
(CLOCK_REALTIME, `time.time_ns()`) when the client had the whole message.

Usage: latency_ws.py ws://127.0.0.1:PORT
"""
import asyncio
import json
import struct
import sys
import time

import websockets


async def main(url):
    ws = await websockets.connect(url, subprotocols=["foxglove.websocket.v1"], max_size=None,
                                  ping_interval=None)
    subs, log = {}, []

    async def subscribe(channels):
        new = []
        for c in channels:
            if all(c["id"] != d["id"] for d in subs.values()):
                subs[len(subs)] = c
                new.append({"id": len(subs) - 1, "channelId": c["id"]})
        if new:
            await ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))
        return bool(new)

    try:
        async for msg in ws:
            now = time.time_ns()
            if isinstance(msg, str):
                text = json.loads(msg)
                if text["op"] == "serverInfo":
                    print("ready", flush=True)
                elif text["op"] == "advertise":
                    await subscribe(text["channels"])
                continue
            if msg[0] != 0x01:
                continue
            sub, log_time = struct.unpack_from("<IQ", msg, 1)
            log.append([subs[sub]["topic"], log_time, now])
    except websockets.ConnectionClosed:
        pass
    print(json.dumps({"messages": log}), flush=True)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1]))
