"""Gantt chart of a mission: one row per UAV, one bar per attempt, coloured by task kind, failures marked."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from masonry.errors import InputError

KIND_COLOURS = {"brick": "#c0504d", "adhesion": "#4f81bd"}
FAILED_COLOUR = "#7f7f7f"


def draw_gantt(report: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Draw ``report`` (a :class:`~masonry.mission.report.MissionReport`) to ``path`` (.png or .svg).

    Each attempt is a bar from its assignment to its end; a failed attempt is grey, hatched, and marked
    with an x and its reason; a UAV's loss is a black vertical tick at the end of its row.

    Raises:
        InputError: the file extension is neither .png nor .svg.
    """
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"`gantt` {path}: the file must end in .png or .svg", options=("gantt",))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    uavs = [u.name for u in report.uavs]
    row = {name: i for i, name in enumerate(uavs)}
    end = max([report.makespan_s] + [a.end_s or a.start_s for a in report.attempts] + [1.0])
    fig, ax = plt.subplots(
        figsize=(max(8.0, min(24.0, 6.0 + len(report.attempts) * 0.08)), 1.0 + 0.6 * max(1, len(uavs)))
    )
    for a in report.attempts:
        y = row.get(a.uav)
        if y is None:
            continue
        stop = a.end_s if a.end_s is not None else end
        width = max(stop - a.start_s, end * 1e-3)
        if a.status == "failed":
            ax.barh(
                y,
                width,
                left=a.start_s,
                height=0.6,
                color=FAILED_COLOUR,
                hatch="//",
                edgecolor="black",
                linewidth=0.5,
            )
            ax.plot([stop], [y], marker="x", color="black", markersize=8)
            if a.reason:
                ax.annotate(a.reason, (stop, y + 0.35), fontsize=6, ha="center")
        else:
            ax.barh(
                y,
                width,
                left=a.start_s,
                height=0.6,
                color=KIND_COLOURS.get(a.kind, "#9bbb59"),
                edgecolor="black",
                linewidth=0.5,
            )
        if len(report.attempts) <= 60:
            ax.text(
                a.start_s + width / 2.0, y, a.task_id, ha="center", va="center", fontsize=7, color="white"
            )
    for u in report.uavs:
        if u.status != "ok":
            ax.plot([end], [row[u.name]], marker="|", color="black", markersize=16)
            ax.annotate(u.status, (end, row[u.name] - 0.4), fontsize=7, ha="right")
    ax.set_yticks(range(len(uavs)), uavs)
    ax.invert_yaxis()
    ax.set_xlabel("mission time [s]")
    ax.set_xlim(0.0, end * 1.02)
    ax.grid(axis="x", alpha=0.3)
    ax.legend(
        handles=[
            Patch(color=KIND_COLOURS["brick"], label="brick"),
            Patch(color=KIND_COLOURS["adhesion"], label="adhesion"),
            Patch(facecolor=FAILED_COLOUR, hatch="//", label="failed attempt"),
        ],
        loc="upper left",
        bbox_to_anchor=(1.0, 1.0),
        fontsize=7,
    )
    ax.set_title(
        title or f"mission ({report.policy}, seed {report.seed}): makespan {report.makespan_s:.1f} s"
    )
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
