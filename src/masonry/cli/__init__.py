"""The ``masonry`` command line: a thin layer over the public API (see ``masonry --help``)."""

from __future__ import annotations

import sys

from masonry.cli import commands as _commands  # noqa: F401  (registers every command on the app)
from masonry.cli.app import app

__all__ = ["app", "main"]


def main() -> None:
    """Entry point of the ``masonry`` console script.

    A usage error (an unknown option, a value of the wrong type) is one ``error:`` line and exit status 2, like
    every other bad input, instead of click's boxed usage text.
    """
    import typer
    import typer.main

    try:  # typer 0.2x vendors click; older ones use the click package
        from typer._click import exceptions as click_exceptions
    except ImportError:  # pragma: no cover - depends on the installed typer
        from click import exceptions as click_exceptions  # type: ignore[no-redef]

    command = typer.main.get_command(app)
    try:
        status = command.main(prog_name="masonry", standalone_mode=False)
    except click_exceptions.UsageError as exc:
        message = exc.format_message()
        if message:  # no message: the command's help was printed (no_args_is_help)
            where = exc.ctx.command_path if exc.ctx is not None else "masonry"
            print(f"error: {message} (see {where} --help)", file=sys.stderr)
        sys.exit(exc.exit_code)
    except click_exceptions.ClickException as exc:
        print(f"error: {exc.format_message()}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except typer.Abort:
        print("error: interrupted", file=sys.stderr)
        sys.exit(130)
    sys.exit(status if isinstance(status, int) else 0)
