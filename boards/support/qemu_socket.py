"""Connecting to a serial port QEMU serves on a socket (`-serial unix:PATH,server=on,wait=on`,
or `tcp:127.0.0.1:PORT,...`), for the boards' checker (qemu_link_check.py, beside this module)."""
import os
import socket
import time


def connect(address: str, deadline: float) -> socket.socket:
    """Connects to `address` (a Unix socket's path, or HOST:PORT), retrying every 50 ms until
    QEMU listens; raises the last error once `time.monotonic()` passes `deadline`."""
    while True:
        try:
            if ":" in address and os.path.sep not in address:
                host, port = address.rsplit(":", 1)
                return socket.create_connection((host, int(port)), timeout=1)
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.connect(address)
            return s
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)
