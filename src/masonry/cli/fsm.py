"""``masonry fsm diagram``: draw the brick or adhesion UAV's nested state machine."""

from __future__ import annotations

from pathlib import Path

import typer

from masonry.cli.app import app, command
from masonry.cli.outputs import atomic_path, check_output_path
from masonry.errors import InputError

fsm_app = typer.Typer(help="The UAVs' state machines.", no_args_is_help=True)
app.add_typer(fsm_app, name="fsm")


@command("diagram", typer_app=fsm_app)
def diagram(
    machine: str = typer.Argument(..., help="brick | adhesion."),
    output: Path = typer.Option(
        ...,
        "-o",
        "--output",
        help="Output file: .svg, .png or .dot (graphviz text). SVG/PNG are drawn "
        "by graphviz's dot when it is installed, else by a built-in layout.",
    ),
) -> None:
    r"""Render a UAV's nested state machine (states, triggers, \[conditions]) as SVG, PNG or DOT."""
    from masonry.fsm.diagram import FORMATS, write_diagram
    from masonry.fsm.states import MACHINES

    if machine not in MACHINES:
        raise InputError(f"unknown machine {machine!r}: expected brick or adhesion")
    fmt = output.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise InputError(f"{output}: the file must end in .svg, .png or .dot")
    check_output_path(output, "--output")
    try:
        with atomic_path(output, "--output") as tmp:
            write_diagram(machine, tmp)
    except OSError as exc:
        raise InputError(f"{output}: cannot write the diagram ({exc.strerror or exc})") from exc
    typer.echo(f"wrote {output}")
