"""The ``masonry`` command line: a thin layer over the public API (see ``masonry --help``)."""

from __future__ import annotations

from masonry.cli import commands as _commands  # noqa: F401  (registers every command on the app)
from masonry.cli.app import app

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``masonry`` console script."""
    app()
