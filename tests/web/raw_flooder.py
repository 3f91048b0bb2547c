"""A hostile page for the station's tests, in its own process: floods raw bytes over a WebSocket
the test opened by hand, reading whatever comes back, until its standard input closes.

``python raw_flooder.py FD HEX COUNT``: ``FD`` is the inherited socket's file descriptor, ``HEX``
the bytes to send (hexadecimal), sent ``COUNT`` times in one write, over and over. Prints
``flooding`` once it has started. Being a process of its own, it floods on the other core and
holds none of the test process's interpreter lock (a real hostile page is another program).
"""

from __future__ import annotations

import socket
import sys
import threading
import time

MAX_S = 60.0  # guard: a flooder whose test died does not run on


def main() -> None:
    fd, data = int(sys.argv[1]), bytes.fromhex(sys.argv[2]) * int(sys.argv[3])
    sock = socket.socket(fileno=fd)
    done = threading.Event()
    give_up = time.monotonic() + MAX_S

    def send() -> None:
        try:
            while not done.is_set() and time.monotonic() < give_up:
                sock.sendall(data)
        except OSError:
            pass

    def read() -> None:
        try:
            while not done.is_set() and sock.recv(1 << 20):
                pass
        except OSError:
            pass

    threads = [
        threading.Thread(target=send, daemon=True),
        threading.Thread(target=read, daemon=True),
    ]
    for thread in threads:
        thread.start()
    print("flooding", flush=True)
    sys.stdin.read()  # until the test closes it
    done.set()
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    for thread in threads:
        thread.join(5.0)
    sock.close()


if __name__ == "__main__":
    main()
