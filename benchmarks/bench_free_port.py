"""A "free" UDP port taken between its draw and the caller's bind: the kernel's port against ``free_udp_port``'s.

The SITL tests draw a port, start a SITL that sends to it, then bind it (the adapter's ``udpin``, pymavlink's
``SO_REUSEADDR``). Meanwhile any socket that sends before it binds (every SITL's, every ``udpout`` link's, on the
whole machine) is given a port by the kernel from its ephemeral range; issue 29's SITL load loop's run 15 failed
on "Address already in use". Each trial here draws a port, then opens ``--senders`` unbound sockets that each send
one datagram (the kernel binds them), then binds the drawn port as the adapter does, and counts the binds refused:
for a port from ``bind(host, 0)`` (the draw before) and from ``masonry.adapters.sitl.free_udp_port`` (below the
ephemeral range). Prints both counts; asserts nothing.

Usage: python benchmarks/bench_free_port.py [--trials 20000] [--senders 10]
"""

from __future__ import annotations

import argparse
import socket
from collections.abc import Callable

from masonry.adapters.sitl import free_udp_port

HOST = "127.0.0.1"


def kernel_port() -> int:
    """The draw before: the port the kernel gives a bind to port 0 (in its ephemeral range)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind((HOST, 0))
        return int(sock.getsockname()[1])


def refused(draw: Callable[[], int], trials: int, senders: int) -> int:
    """How many of ``trials`` binds of a drawn port were refused after ``senders`` unbound sockets sent once."""
    count = 0
    for _ in range(trials):
        port = draw()
        others = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(senders)]
        try:
            for other in others:
                other.sendto(
                    b"x", (HOST, 9)
                )  # the discard port: the kernel binds the sender on its ephemeral range
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as pymavlink's udpin
                try:
                    sock.bind((HOST, port))
                except OSError:
                    count += 1
        finally:
            for other in others:
                other.close()
    return count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=20000)
    ap.add_argument("--senders", type=int, default=10, help="unbound sockets that send between draw and bind")
    args = ap.parse_args()
    for name, draw in (("bind(0), before", kernel_port), ("free_udp_port", free_udp_port)):
        n = refused(draw, args.trials, args.senders)
        print(
            f"{name}: {n} of {args.trials} binds refused ({args.senders} unbound senders between draw and bind)"
        )


if __name__ == "__main__":
    main()
