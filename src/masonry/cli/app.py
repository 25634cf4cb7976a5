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


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            typer.echo(f"masonry {version('masonry')}")
        except PackageNotFoundError:  # run from a source tree that was never installed
            typer.echo("masonry (not installed)")
        raise typer.Exit()


@app.callback()
def _main(
    show_version: bool = typer.Option(
        False, "--version", callback=_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Autonomous aerial masonry: plan walls, fly brick and adhesion UAVs, simulate whole missions."""


def _option_type(self: Any, ctx: Any) -> str | None:
    """What ``--help`` shows after an option: nothing for a flag, ``<str>`` for a repeatable option (not
    ``<list[str]>``), ``<float> <float> <float>`` for a tuple (the values are separate words, not commas)."""
    if self.metavar is not None and not isinstance(self, _TyperArgument):  # an argument's metavar is its name
        return str(self.metavar)
    if getattr(self, "is_flag", False):
        return None
    desc = self.type_descriptor
    if desc.is_tuple and not desc.is_list:
        from typing import get_args

        return " ".join(f"<{self._bare_type(arg)}>" for arg in get_args(desc.annotation))
    if desc.is_list and not desc.is_choice:
        from typing import get_args

        args = get_args(desc.annotation)
        if len(args) == 1:
            return f"<{self._bare_type(args[0]).lower()}>"
    metavar: str | None = _original[type(self)](self, ctx)
    return metavar


_original: dict[type, Any] = {}
try:  # typer 0.2x prints a type after every option; the defaults mislead for flags, lists and tuples
    from typer.core import TyperArgument as _TyperArgument
    from typer.core import TyperOption as _TyperOption

    for _cls in (_TyperOption, _TyperArgument):
        _original[_cls] = _cls.display_type_rich
        _cls.display_type_rich = _option_type  # type: ignore[method-assign]
except (ImportError, AttributeError):  # another typer: keep its own rendering
    pass

#: Errors caused by what the user gave us exit with 2 (like a usage error); the rest exit with 1.
USER_ERRORS: tuple[type[MasonryError], ...] = (
    BlueprintError,
    InputError,
    JournalUnusable,
    PerceptionError,
    ProtocolError,
)


#: Library parameters named in errors (``MasonryError.options``) whose flag is not ``--`` + the name with dashes.
OPTION_FLAGS = {"estimate_timeout_s": "--estimate-wait", "journal_path": "--journal"}


def cli_text(text: str, options: tuple[str, ...]) -> str:
    """``text`` in the CLI's terms: each parameter of ``options`` it names (```key_file```) becomes its flag."""
    for name in options:
        flag = OPTION_FLAGS.get(name, "--" + name.replace("_", "-"))
        text = text.replace(f"`{name}`", flag)
    return text


def cli_message(exc: MasonryError) -> str:
    """The error's line in the CLI's terms (:func:`cli_text` of its ``options``)."""
    return cli_text(str(exc), exc.options)


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
            raise fail(cli_message(exc), 2 if isinstance(exc, USER_ERRORS) else 1) from exc
        except KeyboardInterrupt:
            raise fail("interrupted", 130) from None

    return wrapper  # type: ignore[return-value]


def command(*args: Any, typer_app: typer.Typer | None = None, **kwargs: Any) -> Callable[[F], F]:
    """Register a command on ``typer_app`` (the main app by default) behind the error boundary."""

    def decorate(func: F) -> F:
        (typer_app or app).command(*args, **kwargs)(guarded(func))
        return func

    return decorate
