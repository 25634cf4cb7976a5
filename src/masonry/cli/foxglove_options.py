"""``--foxglove [HOST:]PORT`` (with ``--foxglove-cert``/``--foxglove-key``) of ``masonry sim``, ``masonry
mission-control`` and ``masonry replay``: the mission live in Foxglove (docs/observe.md, docs/security.md)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import typer

from masonry.errors import InputError

FOXGLOVE_OPTION = typer.Option(
    None,
    "--foxglove",
    metavar="[HOST:]PORT",
    help='Serve the mission live to Foxglove here ("Open connection", ws://HOST:PORT; host 127.0.0.1 by '
    "default): the log's channels, and on loopback the operator's commands as services; docs/observe.md.",
)
FOXGLOVE_CERT_OPTION = typer.Option(
    None,
    "--foxglove-cert",
    metavar="CERT.pem",
    help="With --foxglove: serve wss:// with this TLS certificate (PEM; with --foxglove-key). Needed to serve "
    "on a host that is not loopback; docs/security.md.",
)
FOXGLOVE_KEY_OPTION = typer.Option(
    None, "--foxglove-key", metavar="KEY.pem", help="With --foxglove-cert: its private key (PEM, PKCS#8)."
)


@dataclass(frozen=True)
class FoxgloveAt:
    """Where to serve Foxglove, and how: ``tls`` (certificate, key) PEM bytes or None; ``steer``: the services."""

    host: str
    port: int
    tls: tuple[bytes, bytes] | None
    steer: bool


def loopback(host: str) -> bool:
    """``host`` is this machine only (``localhost``, 127.0.0.0/8, ::1)."""
    import ipaddress

    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def foxglove_option(spec: str | None, cert: Path | None, key: Path | None) -> FoxgloveAt | None:
    """``--foxglove`` and its TLS files, checked before the mission starts.

    A host that is not loopback needs TLS (``--foxglove-cert`` and ``--foxglove-key``): the Foxglove protocol
    authenticates no viewer, so there the channels are served over ``wss://`` and the operator's services are not
    offered (steer from loopback, from ``masonry ctl`` with the mission key, or from the terminal's keys).

    Raises:
        InputError: a bad ``[HOST:]PORT``, one TLS file without the other or unreadable, TLS files without
            ``--foxglove``, or a host that is not loopback without TLS.
    """
    from masonry.observe.web import parse_serve

    if spec is None:
        if cert is not None or key is not None:
            raise InputError("--foxglove-cert and --foxglove-key go with --foxglove [HOST:]PORT")
        return None
    host, port = parse_serve(spec, "foxglove")
    if (cert is None) != (key is None):
        raise InputError(
            "--foxglove-cert and --foxglove-key go together (the certificate and its private key)"
        )
    tls = None
    if cert is not None and key is not None:
        pems = []
        for flag, p in (("--foxglove-cert", cert), ("--foxglove-key", key)):
            try:
                pems.append(p.read_bytes())
            except OSError as exc:
                raise InputError(f"{flag} {p}: cannot read it: {exc.strerror or exc}") from None
            if b"-----BEGIN " not in pems[-1]:
                raise InputError(f"{flag} {p}: not a PEM file")
        tls = (pems[0], pems[1])
    if tls is None and not loopback(host):
        raise InputError(
            f"--foxglove {spec} is not loopback: give --foxglove-cert FILE and --foxglove-key FILE to serve it "
            "over TLS (wss://), or serve on 127.0.0.1 (docs/security.md)"
        )
    return FoxgloveAt(host, port, tls, steer=loopback(host))


__all__ = [
    "FOXGLOVE_CERT_OPTION",
    "FOXGLOVE_KEY_OPTION",
    "FOXGLOVE_OPTION",
    "FoxgloveAt",
    "foxglove_option",
    "loopback",
]
