"""Gantt chart of an offline schedule: one row per UAV, one bar per planned task (site parts darker)."""

from __future__ import annotations

from pathlib import Path

from masonry.planner.schedule_values import OfflineSchedule
from masonry.viz.gantt import KIND_COLOURS


def draw_schedule_gantt(schedule: OfflineSchedule, path: Path | str, *, title: str = "") -> None:
    """Draw ``schedule`` to ``path`` (.png or .svg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12, 0.5 + 0.45 * max(1, len(schedule.uavs))))
    try:
        for row, u in enumerate(schedule.uavs):
            colour = KIND_COLOURS.get(u.role, "#9bbb59")
            for t in u.tasks:
                ax.barh(row, t.end_s - t.start_s, left=t.start_s, color=colour, edgecolor="white", height=0.7)
                if t.site_start_s is not None and t.site_end_s is not None:
                    ax.barh(
                        row,
                        t.site_end_s - t.site_start_s,
                        left=t.site_start_s,
                        color="black",
                        alpha=0.35,
                        height=0.7,
                    )
        ax.set_yticks(range(len(schedule.uavs)), [u.name for u in schedule.uavs])
        ax.invert_yaxis()
        ax.set_xlabel("planned time, s")
        ax.set_title(
            title
            + f" (makespan {schedule.makespan_s:.0f} s, bound {schedule.bound_s:.0f} s, {schedule.status})"
        )
        fig.tight_layout()
        fig.savefig(str(path), format=Path(path).suffix.lstrip(".").lower() or "png")
    finally:
        plt.close(fig)


__all__ = ["draw_schedule_gantt"]
