"""The typer application and the error boundary every command goes through.

Commands live in sibling modules (one per area) and register with :func:`command`; they parse, wire
adapters, call the public API and print. Heavy libraries are imported inside the command bodies so that
``masonry --help`` stays fast.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, TypeVar

import typer

from masonry.errors import (
    BlueprintError,
    InputError,
    JournalUnusable,
    MasonryError,
    PerceptionError,
    ProtocolError,
)

F = TypeVar("F", bound=Callable[..., Any])

app = typer.Typer(
    name="masonry",
    help="Autonomous aerial masonry: plan walls, fly brick and adhesion UAVs, simulate whole missions.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

#: Errors caused by what the user gave us exit with 2 (like a usage error); the rest exit with 1.
USER_ERRORS: tuple[type[MasonryError], ...] = (
    BlueprintError, InputError, JournalUnusable, PerceptionError, ProtocolError)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``message`` as one line on stderr and return the Exit to raise."""
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(code)


def guarded(func: F) -> F:
    """Turn a MasonryError escaping ``func`` into one line on stderr and an exit status (never a traceback)."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except MasonryError as exc:
            raise fail(str(exc), 2 if isinstance(exc, USER_ERRORS) else 1) from exc
        except KeyboardInterrupt:
            raise fail("interrupted", 130) from None

    return wrapper  # type: ignore[return-value]


def command(*args: Any, typer_app: typer.Typer | None = None, **kwargs: Any) -> Callable[[F], F]:
    """Register a command on ``typer_app`` (the main app by default) behind the error boundary."""

    def decorate(func: F) -> F:
        (typer_app or app).command(*args, **kwargs)(guarded(func))
        return func

    return decorate
