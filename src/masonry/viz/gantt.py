"""Gantt chart of a mission: one row per UAV, one bar per attempt, split by phase, failures marked.

An attempt whose UAV reported its phases (:class:`~masonry.ports.PhaseTimes`) is drawn as segments in the order
of :data:`~masonry.ports.PHASES`, each as long as the seconds spent in that phase (scaled to fill the bar: the
bar runs from the assignment to the result at mission control, one message delay longer than the UAV's own
count). The segments say how much of the attempt went to each phase, not when: a UAV may wait, fly and wait
again. An attempt without phases is coloured by its task kind.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from masonry.errors import InputError
from masonry.ports import PhaseTimes

KIND_COLOURS = {"brick": "#c0504d", "adhesion": "#4f81bd"}
FAILED_COLOUR = "#7f7f7f"
#: One colour per phase (waits in reds, so that they stand out; flights in blues; the work in greens and purples).
PHASE_COLOURS = {
    "queued": "#d9d9d9",
    "takeoff": "#8c564b",
    "transit": "#6baed6",
    "waiting": "#d62728",
    "holding": "#ff9896",
    "estimating": "#9467bd",
    "aligning": "#c5b0d5",
    "descending": "#2ca02c",
    "grasping": "#bcbd22",
    "spraying": "#17becf",
    "placing": "#e377c2",
    "ascending": "#98df8a",
    "other": "#525252",
}


OTHER_KIND_COLOUR = "#9bbb59"
#: The open window of a bead (issue 31): a thin band under its adhesion UAV's row, from the bead's end.
OPEN_WINDOW_COLOUR = "#17becf"


def open_windows(report: Any) -> list[tuple[str, str, float, float]]:
    """Per bead that was sprayed (a done or expired adhesion attempt): (UAV, bead id, start s, end s) of its open
    window, from the end of the spraying to the end of the open time; none without an open time."""
    open_s = getattr(report, "open_time_s", None)
    if open_s is None:
        return []
    return [
        (a.uav, a.task_id, a.end_s, a.end_s + open_s)
        for a in report.attempts
        if a.kind == "adhesion"
        and a.end_s is not None
        and (a.status == "done" or a.reason == "open time expired")
    ]


@dataclass
class _Bars:
    """The coloured spans of the attempts that did not fail, gathered per row and colour (drawn in one call each).

    ``segments``: (row, colour) -> (left, width) spans; ``outlines``: row -> the attempts' whole spans;
    ``phases`` and ``kinds``: what was drawn, for the legend.
    """

    segments: dict[tuple[int, str], list[tuple[float, float]]] = field(default_factory=dict)
    outlines: dict[int, list[tuple[float, float]]] = field(default_factory=dict)
    phases: set[str] = field(default_factory=set)
    kinds: set[str] = field(default_factory=set)

    def add(self, y: int, left: float, width: float, kind: str, phases: PhaseTimes | None) -> None:
        """One attempt's bar: its phases' segments end to end, in proportion (or its kind's colour)."""
        self.outlines.setdefault(y, []).append((left, width))
        total = phases.total_s if phases is not None else 0.0
        if phases is None or total <= 0:
            self.segments.setdefault((y, KIND_COLOURS.get(kind, OTHER_KIND_COLOUR)), []).append((left, width))
            self.kinds.add(kind)
            return
        for name, seconds in phases.items():
            if seconds <= 0:
                continue
            w = width * seconds / total
            self.segments.setdefault((y, PHASE_COLOURS[name]), []).append((left, w))
            self.phases.add(name)
            left += w


def draw_gantt(report: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Draw ``report`` (a :class:`~masonry.mission.report.MissionReport`) to ``path`` (.png or .svg).

    Each attempt is a bar from its assignment to its end, split by phase (see the module docstring); a failed
    attempt is grey, hatched, and marked with an x and its reason; a UAV's loss is a black vertical tick at the
    end of its row. The legend names the phases drawn.

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
        figsize=(
            max(8.0, min(24.0, 6.0 + len(report.attempts) * 0.08)),
            max(2.6, 1.0 + 0.6 * max(1, len(uavs))),  # at least the legend's height
        )
    )
    bars = _Bars()
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
            bars.add(y, a.start_s, width, a.kind, getattr(a, "phases", None))
        if len(report.attempts) <= 60:
            split = a.status != "failed" and getattr(a, "phases", None) is not None
            ax.text(
                a.start_s + width / 2.0,
                y,
                a.task_id,
                ha="center",
                va="center",
                fontsize=7,
                color="black" if split else "white",
            )
    for (y, colour), spans in bars.segments.items():
        ax.broken_barh(spans, (y - 0.3, 0.6), facecolors=colour, linewidth=0)
    for y, spans in bars.outlines.items():
        ax.broken_barh(spans, (y - 0.3, 0.6), facecolors="none", edgecolors="black", linewidth=0.5)
    windows = open_windows(report)
    for uav, _, t0, t1 in windows:
        if uav in row:
            ax.broken_barh([(t0, t1 - t0)], (row[uav] + 0.3, 0.1), facecolors=OPEN_WINDOW_COLOUR, alpha=0.5)
    for u in report.uavs:
        if u.status != "ok":
            ax.plot([end], [row[u.name]], marker="|", color="black", markersize=16)
            ax.annotate(u.status, (end, row[u.name] - 0.4), fontsize=7, ha="right")
    ax.set_yticks(range(len(uavs)), uavs)
    ax.invert_yaxis()
    ax.set_xlabel("mission time [s]")
    ax.set_xlim(0.0, end * 1.02)
    ax.grid(axis="x", alpha=0.3)
    handles = [Patch(color=PHASE_COLOURS[name], label=name) for name in PHASE_COLOURS if name in bars.phases]
    handles += [
        Patch(color=KIND_COLOURS.get(kind, OTHER_KIND_COLOUR), label=f"{kind} (no phases)")
        for kind in sorted(bars.kinds)
    ]
    handles.append(Patch(facecolor=FAILED_COLOUR, hatch="//", label="failed attempt"))
    if windows:
        handles.append(Patch(color=OPEN_WINDOW_COLOUR, alpha=0.5, label="bead open window"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    ax.set_title(
        title or f"mission ({report.policy}, seed {report.seed}): makespan {report.makespan_s:.1f} s"
    )
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
