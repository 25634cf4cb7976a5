"""``masonry plan``, ``masonry schema`` and ``masonry blueprint running-bond|towers|pyramid``."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from masonry.cli.app import app, command
from masonry.cli.options import MAX_GENERATED_BRICKS, check_all, help_text, plural
from masonry.cli.outputs import atomic_path, check_output_path, check_output_paths, write_atomic
from masonry.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from masonry.blueprint import Blueprint
    from masonry.planner.deadlines import Deadline
    from masonry.planner.graphs import PlanGraphs

GRAPH_FORMATS = (".png", ".svg", ".dot", ".graphml")
#: Plans with at most this many tasks to do list every task in the text summary.
DETAIL_LIMIT = 40


@command("plan")
def plan_command(
    blueprint: Path = typer.Argument(..., help="Wall blueprint (YAML; see docs/blueprint-format.md)."),
    fmt: str = typer.Option("text", "--format", help="text (a human summary) | json."),
    output: Path | None = typer.Option(None, "--output", "-o", help="Write the output to this file."),
    graph: Path | None = typer.Option(
        None, "--graph", help="Draw/export G^d and G^c together: .png, .svg, .dot or .graphml."
    ),
    planner_only: bool = typer.Option(
        False,
        "--planner-only",
        help="Plan a wall whose marker ids do not fit its dictionary (over 1160 bricks without `marker` "
        "numbers): skips the marker checks, for planner studies; such a wall cannot be flown.",
    ),
) -> None:
    """Plan a wall: tasks, dependency graph G^d, conflict graph G^c (paper Section III)."""
    from masonry.blueprint import load_blueprint
    from masonry.planner.graphs import plan_graphs

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if graph is not None and graph.suffix.lower() not in GRAPH_FORMATS:
        raise InputError(f"--graph {graph}: the file must end in {', '.join(GRAPH_FORMATS)}")
    check_output_paths([("--output", output), ("--graph", graph)])
    bp = load_blueprint(blueprint, check_marker_ids=not planner_only)
    # conflicts stay arrays: a 20,000-brick wall has millions of them
    result = plan_graphs(bp, check_marker_ids=not planner_only)
    if fmt == "json":
        from masonry.planner.export import iter_plan_json

        _write(iter_plan_json(result), output)
    else:
        _write([summary(bp, result)], output)
    if graph is not None:
        from masonry.viz.graph_drawing import export_graphs

        with atomic_path(graph, "--graph") as tmp:
            export_graphs(result.to_plan(), tmp, title=bp.name or blueprint.name)
        typer.echo(f"wrote {graph}", err=True)


def _write(pieces: Any, output: Path | None) -> None:
    if output is None:
        for piece in pieces:
            sys.stdout.write(piece)
        sys.stdout.flush()
        return
    with atomic_path(output, "--output") as tmp, tmp.open("w", encoding="utf-8") as fh:
        for piece in pieces:
            fh.write(piece)
    typer.echo(f"wrote {output}", err=True)


def summary(bp: Blueprint, result: PlanGraphs) -> str:
    """The human summary of a plan: counts, tasks available at the start, the longest chain."""
    from masonry.planner.tasks import available, longest_chain

    bricks = bp.bricks
    placed = sum(1 for b in bricks if b.placed)
    todo = [t for t in result.tasks if not t.done]
    n_brick = sum(1 for t in todo if t.kind == "brick")
    n_adh = len(todo) - n_brick
    ready = available(result.tasks, result.dependencies)
    chain = longest_chain(result.tasks, result.dependencies)
    fleet = ", ".join(f"{u.name} ({u.role})" for u in bp.fleet) or "none"
    lines = [
        f"{bp.name or Path(bp.source).stem}  ({bp.source})",
        f"  bricks          {len(bricks)}: {placed} placed, {len(bricks) - placed} to place",
        f"  tasks to do     {len(todo)}: {n_brick} brick, {n_adh} adhesion",
        f"  dependencies    {plural(len(result.dependencies), 'edge')} in G^d",
        f"  conflicts       {plural(result.conflict_count, 'pair')} in G^c (clearance r_c = {bp.clearance_m:g} m)",
        f"  fleet           {fleet}",
        *_adhesive_lines(bp, result.deadlines),
        f"  available now   {_id_list(ready)}",
        # longest_chain lists the top task first; shown in execution order (the first task to do first)
        f"  longest chain   {plural(len(chain), 'task')}: {_chain(chain[::-1])}",
    ]
    if 0 < len(todo) <= DETAIL_LIMIT:
        full = result.to_plan()
        prereq = full.prerequisites()
        done = {x.id for x in result.tasks if x.done}
        conflicts: dict[str, list[str]] = {t.id: [] for t in todo}
        for a, b in full.conflicts:
            conflicts[a].append(b)
            conflicts[b].append(a)
        lines.append("")
        lines.append("  task  what                                        waits for         conflicts with")
        for t in todo:
            if t.kind == "brick":
                what = f"place brick {t.brick} at {_xyz(t.position_m)}"  # type: ignore[union-attr]
            else:
                what = f"glue {t.length_m:.2f} m on brick {t.below} under {t.above}"  # type: ignore[union-attr]
            waits = ", ".join(v + (" (done)" if v in done else "") for v in prereq[t.id]) or "-"
            lines.append(f"  {t.id:<5} {what:<43} {waits:<17} {', '.join(conflicts[t.id]) or '-'}")
    return "\n".join(lines) + "\n"


def _xyz(p: tuple[float, float, float]) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


def _id_list(ids: list[str], limit: int = 12) -> str:
    if not ids:
        return "none"
    shown = ", ".join(ids[:limit])
    return f"{len(ids)}: {shown}" + (f", ... ({len(ids) - limit} more)" if len(ids) > limit else "")


def _chain(chain: list[str], limit: int = 9) -> str:
    if not chain:
        return "-"
    if len(chain) <= limit:
        return " -> ".join(chain)
    return " -> ".join(chain[:4]) + " -> ... -> " + " -> ".join(chain[-4:])


@command("schema")
def schema_command() -> None:
    """Print the JSON Schema of the blueprint format (for editors and validators)."""
    import json

    from masonry.schema import blueprint_schema

    typer.echo(json.dumps(blueprint_schema(), indent=2))


blueprint_app = typer.Typer(
    help="Generate blueprints of any size (running-bond walls, towers, pyramids).", no_args_is_help=True
)
app.add_typer(blueprint_app, name="blueprint")


def _common(
    output: Path | None,
    brick_size: tuple[float, float, float] | None,
    joint: float,
    yaw: float,
    origin: tuple[float, float],
    placed_courses: int,
    pallet_columns: int,
    brick_uavs: int,
    adhesion_uavs: int,
    clearance: float,
    cruise_altitude: float | None,
    name: str | None,
) -> dict[str, Any]:
    options: dict[str, Any] = {
        "joint_m": joint,
        "yaw_rad": yaw,
        "origin_m": origin,
        "placed_courses": placed_courses,
        "pallet_columns": pallet_columns,
        "brick_uavs": brick_uavs,
        "adhesion_uavs": adhesion_uavs,
        "clearance_m": clearance,
    }
    if cruise_altitude is not None:
        options["cruise_altitude_m"] = cruise_altitude
    if brick_size is not None:
        options["brick_size_m"] = brick_size
    if name:
        options["name"] = name
    return options


def _argv(options: dict[str, Any]) -> str:
    """The generator options as command-line flags (recorded in the file's header)."""
    flags = {
        "joint_m": "joint",
        "yaw_rad": "yaw",
        "origin_m": "origin",
        "spacing_m": "spacing",
        "clearance_m": "clearance",
        "cruise_altitude_m": "cruise-altitude",
        "brick_size_m": "brick-size",
    }
    parts = []
    for key, value in options.items():
        flag = flags.get(key, key.replace("_", "-"))
        if isinstance(value, (tuple, list)):
            text = " ".join(f"{v:g}" for v in value)
        elif isinstance(value, float):
            text = f"{value:g}"
        else:
            text = str(value)
        parts.append(f"--{flag} {text}")
    return " " + " ".join(parts) if parts else ""


#: The generator keyword of each range-checked option (docs/cli.md lists the ranges).
_GEN_FLAGS = {
    "courses": "--courses",
    "bricks_per_course": "--bricks-per-course",
    "towers": "--towers",
    "height": "--height",
    "base": "--base",
    "spacing_m": "--spacing",
    "brick_size_m": "--brick-size",
    "joint_m": "--joint",
    "yaw_rad": "--yaw",
    "origin_m": "--origin",
    "placed_courses": "--placed-courses",
    "pallet_columns": "--pallet-columns",
    "brick_uavs": "--brick-uavs",
    "adhesion_uavs": "--adhesion-uavs",
    "clearance_m": "--clearance",
    "cruise_altitude_m": "--cruise-altitude",
    "spares": "--spares",
}


def _check_options(kind: str, options: dict[str, Any]) -> None:
    """Each option within its range, --placed-courses below the wall's courses, the wall not absurdly large."""
    check_all("blueprint", {flag: options[key] for key, flag in _GEN_FLAGS.items() if key in options})
    courses = {
        "running-bond": options.get("courses"),
        "towers": options.get("height"),
        "pyramid": options.get("base"),
    }[kind]
    what = {"running-bond": "--courses", "towers": "--height", "pyramid": "--base"}[kind]
    if options["placed_courses"] > courses:
        raise InputError(
            f"--placed-courses {options['placed_courses']}: more than the wall's {courses} "
            f"courses ({what} {courses})"
        )
    bricks = {
        "running-bond": lambda o: o["courses"] * o["bricks_per_course"],
        "towers": lambda o: o["towers"] * o["height"],
        "pyramid": lambda o: o["base"] * (o["base"] + 1) // 2,
    }[kind](options)
    if bricks > MAX_GENERATED_BRICKS:
        raise InputError(
            f"masonry blueprint {kind}: {bricks} bricks is more than {MAX_GENERATED_BRICKS} "
            f"(the most a generated wall may hold)"
        )


def _emit(kind: str, options: dict[str, Any], output: Path | None) -> None:
    from masonry.blueprint import format_blueprint, validate_blueprint
    from masonry.blueprint_gen import generate
    from masonry.errors import BlueprintError

    _check_options(kind, options)
    check_output_path(output, "--output")
    try:
        bp = generate(kind, **options)
        validate_blueprint(bp)
    except BlueprintError as exc:
        raise InputError(f"masonry blueprint {kind}: {exc.where}: {exc.problem}") from None
    text = format_blueprint(bp, header=f"Generated by: masonry blueprint {kind}{_argv(options)}")
    if output is None:
        sys.stdout.write(text)
        return
    write_atomic(output, text, "--output")
    n_todo = sum(1 for b in bp.bricks if not b.placed)
    typer.echo(
        f"wrote {output}: {plural(len(bp.bricks), 'brick')} ({n_todo} to place), "
        + ("" if bp.spares is None else f"{plural(len(bp.spares), 'spare')}, ")
        + f"{plural(len(bp.fleet), 'UAV')}",
        err=True,
    )


_OUT = typer.Option(None, "--output", "-o", help="Write the blueprint here (default: stdout).")
_BP = "blueprint"
_SIZE = typer.Option(
    None,
    "--brick-size",
    metavar="L W H",
    help=help_text(
        _BP,
        "--brick-size",
        "Brick length, width, height in metres, three numbers separated by spaces (default 0.30 0.15 0.10).",
    ),
)
_JOINT = typer.Option(
    0.0, "--joint", help=help_text(_BP, "--joint", "Gap between neighbouring bricks of a course, metres.")
)
_YAW = typer.Option(
    0.0,
    "--yaw",
    help=help_text(_BP, "--yaw", "Direction of the wall (and its bricks' length axis), radians."),
)
_ORIGIN = typer.Option(
    (0.0, 0.0),
    "--origin",
    metavar="X Y",
    help=help_text(
        _BP, "--origin", "x y of the wall's centre on the ground, metres, two numbers separated by a space."
    ),
)
_PLACED = typer.Option(
    0,
    "--placed-courses",
    help=help_text(
        _BP, "--placed-courses", "How many bottom courses are already in place (at most the wall's courses)."
    ),
)
_PALLET = typer.Option(
    0, "--pallet-columns", help=help_text(_BP, "--pallet-columns", "Pickup pallet columns (0: automatic).")
)
_BUAV = typer.Option(
    1, "--brick-uavs", help=help_text(_BP, "--brick-uavs", "Number of brick UAVs in the fleet.")
)
_AUAV = typer.Option(
    1, "--adhesion-uavs", help=help_text(_BP, "--adhesion-uavs", "Number of adhesion UAVs in the fleet.")
)
_CLEAR = typer.Option(
    1.5, "--clearance", help=help_text(_BP, "--clearance", "Minimum clearance r_c between UAVs, metres.")
)
_CRUISE = typer.Option(
    None,
    "--cruise-altitude",
    help=help_text(
        _BP, "--cruise-altitude", "Cruise altitude, metres (default 1.2, or 0.5 m over a taller wall)."
    ),
)
_NAME = typer.Option(None, "--name", help="Blueprint name (default: <kind>-<bricks>).")
_SPARES = typer.Option(
    None,
    "--spares",
    help=help_text(
        _BP, "--spares", "Spare bricks on the pallet, after the wall's (default: no `spares` key)."
    ),
)


@command("running-bond", typer_app=blueprint_app)
def running_bond_command(
    courses: int = typer.Option(
        4, "--courses", help=help_text(_BP, "--courses", "Number of courses (rows).")
    ),
    bricks_per_course: int = typer.Option(
        6, "--bricks-per-course", help=help_text(_BP, "--bricks-per-course", "Bricks in each course.")
    ),
    output: Path | None = _OUT,
    brick_size: tuple[float, float, float] | None = _SIZE,
    joint: float = _JOINT,
    yaw: float = _YAW,
    origin: tuple[float, float] = _ORIGIN,
    placed_courses: int = _PLACED,
    pallet_columns: int = _PALLET,
    brick_uavs: int = _BUAV,
    adhesion_uavs: int = _AUAV,
    clearance: float = _CLEAR,
    cruise_altitude: float | None = _CRUISE,
    name: str | None = _NAME,
    spares: int | None = _SPARES,
) -> None:
    """A straight running-bond wall: every other course shifted by half a brick."""
    options = _common(
        output,
        brick_size,
        joint,
        yaw,
        origin,
        placed_courses,
        pallet_columns,
        brick_uavs,
        adhesion_uavs,
        clearance,
        cruise_altitude,
        name,
    )
    options.update(courses=courses, bricks_per_course=bricks_per_course)
    options.update({} if spares is None else {"spares": spares})  # (absent: the blueprint of old)
    _emit("running-bond", options, output)


@command("towers", typer_app=blueprint_app)
def towers_command(
    towers: int = typer.Option(2, "--towers", help=help_text(_BP, "--towers", "Number of towers.")),
    height: int = typer.Option(3, "--height", help=help_text(_BP, "--height", "Bricks per tower.")),
    spacing: float = typer.Option(
        1.0, "--spacing", help=help_text(_BP, "--spacing", "Distance between tower centres, metres.")
    ),
    output: Path | None = _OUT,
    brick_size: tuple[float, float, float] | None = _SIZE,
    yaw: float = _YAW,
    origin: tuple[float, float] = _ORIGIN,
    placed_courses: int = _PLACED,
    pallet_columns: int = _PALLET,
    brick_uavs: int = _BUAV,
    adhesion_uavs: int = _AUAV,
    clearance: float = _CLEAR,
    cruise_altitude: float | None = _CRUISE,
    name: str | None = _NAME,
    spares: int | None = _SPARES,
) -> None:
    """Separate stacks of bricks in a row (the paper's case study is --towers 2 --height 3 --placed-courses 2)."""
    options = _common(
        output,
        brick_size,
        0.0,
        yaw,
        origin,
        placed_courses,
        pallet_columns,
        brick_uavs,
        adhesion_uavs,
        clearance,
        cruise_altitude,
        name,
    )
    options.pop("joint_m")
    options.update(towers=towers, height=height, spacing_m=spacing)
    options.update({} if spares is None else {"spares": spares})  # (absent: the blueprint of old)
    _emit("towers", options, output)


@command("pyramid", typer_app=blueprint_app)
def pyramid_command(
    base: int = typer.Option(
        5,
        "--base",
        help=help_text(_BP, "--base", "Bricks in the bottom course (one fewer per course above)."),
    ),
    output: Path | None = _OUT,
    brick_size: tuple[float, float, float] | None = _SIZE,
    joint: float = _JOINT,
    yaw: float = _YAW,
    origin: tuple[float, float] = _ORIGIN,
    placed_courses: int = _PLACED,
    pallet_columns: int = _PALLET,
    brick_uavs: int = _BUAV,
    adhesion_uavs: int = _AUAV,
    clearance: float = _CLEAR,
    cruise_altitude: float | None = _CRUISE,
    name: str | None = _NAME,
    spares: int | None = _SPARES,
) -> None:
    """A stepped pyramid wall."""
    options = _common(
        output,
        brick_size,
        joint,
        yaw,
        origin,
        placed_courses,
        pallet_columns,
        brick_uavs,
        adhesion_uavs,
        clearance,
        cruise_altitude,
        name,
    )
    options.update(base=base)
    options.update({} if spares is None else {"spares": spares})  # (absent: the blueprint of old)
    _emit("pyramid", options, output)


def _adhesive_lines(bp: Blueprint, deadlines: Sequence[Deadline]) -> list[str]:
    """The summary's adhesive line (none without ``adhesive``: the summary of old)."""
    a = bp.adhesive
    if a is None:
        return []
    n_open = sum(1 for d in deadlines if d.kind == "open")
    opened = "no open time" if a.open_time_s is None else f"open time {a.open_time_s:g} s ({n_open} edges)"
    return [f"  adhesive        {opened}, cure time {a.cure_time_s:g} s ({len(deadlines) - n_open} edges)"]
