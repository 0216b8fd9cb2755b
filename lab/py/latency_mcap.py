"""Reads an indexed MCAP file with the `mcap` package and prints one JSON object: every message
as [topic, log_time_ns], and for each chunk the log-time range of its messages and the file
offset where the chunk ends, {"messages": [...], "chunks": [[start_ns, end_ns, end_offset],
...]} in file order.

A message reaches the file when its chunk is written: a reader of the growing file sees it once
the file is at least `end_offset` bytes long.

Usage: latency_mcap.py FILE.mcap
"""
import json
import sys

from mcap.reader import make_reader


def main(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [[channel.topic, message.log_time]
                    for _, channel, message in reader.iter_messages(log_time_order=False)]
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    print(json.dumps({"messages": messages, "chunks": [
        [c.message_start_time, c.message_end_time, c.chunk_start_offset + c.chunk_length]
        for c in chunks]}))


if __name__ == "__main__":
    main(sys.argv[1])
