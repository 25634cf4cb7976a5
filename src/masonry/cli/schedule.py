"""``masonry schedule``: an offline optimised schedule of a wall for a fleet (OR-Tools CP-SAT; docs/schedule.md)."""

from __future__ import annotations

from pathlib import Path

import typer

from masonry.cli.app import cli_message, command, fail
from masonry.cli.options import check_all, help_text
from masonry.cli.outputs import atomic_path, check_output_paths, write_atomic
from masonry.errors import InputError, PlanningError


@command("schedule")
def schedule(
    blueprint: Path = typer.Argument(..., help="Wall blueprint (YAML or JSON)."),
    brick_uavs: int | None = typer.Option(
        None,
        "--brick-uavs",
        help=help_text("schedule", "--brick-uavs", "Number of brick UAVs (overrides the fleet, as sim)."),
    ),
    adhesion_uavs: int | None = typer.Option(
        None,
        "--adhesion-uavs",
        help=help_text(
            "schedule", "--adhesion-uavs", "Number of adhesion UAVs (overrides the fleet, as sim)."
        ),
    ),
    time_limit: float = typer.Option(
        30.0,
        "--time-limit",
        help=help_text("schedule", "--time-limit", "CP-SAT's time for the whole wall, s."),
    ),
    seed: int = typer.Option(0, "--seed", help=help_text("schedule", "--seed", "CP-SAT's random seed.")),
    workers: int = typer.Option(
        2, "--workers", help=help_text("schedule", "--workers", "CP-SAT's workers (1: reproducible).")
    ),
    reservation: str = typer.Option(
        "site",
        "--reservation",
        help="site | task: what conflicting tasks keep apart, as sim (their site parts, or their whole tasks).",
    ),
    decomposition: str = typer.Option(
        "auto",
        "--decomposition",
        help="auto | none | course: the whole model, or course by course (auto: course beyond 110 tasks).",
    ),
    physical: str = typer.Option(
        "",
        "--physical",
        help=(
            "pallet,battery,visit,flown | all (every one but flown; all,flown for every one): the physical terms "
            "(docs/schedule.md, 'The physical model'); none by default."
        ),
    ),
    output: Path | None = typer.Option(
        None, "-o", "--output", help="Write the schedule (JSON) to this file."
    ),
    fmt: str = typer.Option("text", "--format", help="text | json."),
    gantt: Path | None = typer.Option(None, "--gantt", help="Gantt chart of the schedule (.png or .svg)."),
) -> None:
    """Schedule a wall offline: per UAV its ordered tasks with planned times, the makespan and a proven bound.

    `masonry sim --policy schedule --schedule FILE` follows it. Exit status 0, 2 on bad input or without
    OR-Tools (pip install 'masonry[schedule]').
    """
    from masonry.blueprint import load_blueprint
    from masonry.mission.fleet import fleet_for, with_fleet
    from masonry.mission.schedule_file import stamp_schedule
    from masonry.planner import plan as make_plan
    from masonry.planner.schedule import ScheduleUnavailable, physical_terms, solve_schedule
    from masonry.planner.schedule_deadlines import DeadlinesUnmet

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if reservation not in ("site", "task"):
        raise InputError(f"--reservation must be site or task, got {reservation!r}")
    if decomposition not in ("auto", "none", "course"):
        raise InputError(f"--decomposition must be auto, none or course, got {decomposition!r}")
    try:
        terms = physical_terms(physical)
    except PlanningError as exc:
        raise InputError(f"--physical: {exc}") from None
    check_all(
        "schedule",
        {
            "--brick-uavs": brick_uavs,
            "--adhesion-uavs": adhesion_uavs,
            "--time-limit": time_limit,
            "--seed": seed,
            "--workers": workers,
        },
    )
    if gantt is not None and gantt.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"--gantt {gantt}: the file must end in .png or .svg")
    check_output_paths([("-o", output), ("--gantt", gantt)])
    bp = load_blueprint(blueprint)
    fleet = fleet_for(bp, brick_uavs, adhesion_uavs)
    if not fleet:
        raise InputError(
            "the fleet is empty: give --brick-uavs / --adhesion-uavs or a fleet in the blueprint"
        )
    if fleet != bp.fleet:
        bp = with_fleet(bp, fleet)
    try:
        result = solve_schedule(
            make_plan(bp),
            fleet,
            cruise_altitude_m=bp.cruise_altitude_m,
            reservation=reservation,
            time_limit_s=time_limit,
            seed=seed,
            workers=workers,
            decomposition=decomposition,
            physical=terms,
            clearance_m=bp.clearance_m,
        )
    except (ScheduleUnavailable, DeadlinesUnmet) as exc:
        raise fail(cli_message(exc), 2) from None
    result = stamp_schedule(result, bp)
    import json

    text = json.dumps(result.to_dict(), indent=1)
    if output is not None:
        write_atomic(output, text + "\n", "-o")
        typer.echo(f"wrote {output}", err=True)
    if gantt is not None:
        from masonry.viz.schedule_gantt import draw_schedule_gantt

        with atomic_path(gantt, "--gantt") as tmp:
            draw_schedule_gantt(result, tmp, title=f"{bp.name or blueprint.name}: offline schedule")
        typer.echo(f"wrote {gantt}", err=True)
    typer.echo(text if fmt == "json" else result.summary())
