"""G^d and G^c drawn together, like the paper's figure: dependencies as solid arrows, conflicts as dashed lines.

Formats: ``.png``/``.svg`` (matplotlib), ``.dot`` (Graphviz text, written here), ``.graphml`` (networkx).
In the drawing a task sits at its height level (y) and at its position along the wall's main horizontal axis
(x); done tasks (pre-placed bricks) are grey and ticked.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from masonry.errors import InputError
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan, Task

if TYPE_CHECKING:
    import networkx as nx

KIND_COLOURS = {"brick": "#c0504d", "adhesion": "#4f81bd"}
DONE_COLOUR = "#bfbfbf"
CONFLICT_COLOUR = "#e36c09"
FORMATS = (".png", ".svg", ".dot", ".graphml")
#: Above this many tasks the drawing leaves out labels and arrowheads (the graph exports keep everything).
LABEL_LIMIT = 120
#: The drawing shows at most this many conflict pairs (an evenly spaced sample; the title says so).
MAX_DRAWN_CONFLICTS = 20_000


def export_graphs(plan: Plan, path: str | Path, *, title: str | None = None) -> Path:
    """Write G^d and G^c together to ``path``; the format follows the extension (.png, .svg, .dot, .graphml).

    Raises:
        InputError: unknown extension, or the file cannot be written.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise InputError(f"`graph` {path}: the file must end in {', '.join(FORMATS)}", options=("graph",))
    try:
        if suffix == ".dot":
            path.write_text(graph_dot(plan, title=title), encoding="utf-8")
        elif suffix == ".graphml":
            import networkx as nx

            nx.write_graphml(plan_graph(plan), path)
        else:
            draw_graphs(plan, path, title=title)
    except OSError as exc:
        raise InputError(f"`graph` {path}: cannot write: {exc.strerror or exc}", options=("graph",)) from None
    return path


def _location(task: Task) -> tuple[float, float, float]:
    return task.location_m


def plan_graph(plan: Plan) -> nx.DiGraph:
    """Both graphs in one networkx DiGraph: edge attribute ``relation`` is "dependency" (u waits for v) or
    "conflict" (stored once, from the first task of the pair to the second; read it as undirected)."""
    import networkx as nx

    g = nx.DiGraph(name="masonry plan")
    for t in plan.tasks:
        x, y, z = _location(t)
        attrs: dict[str, Any] = {"kind": t.kind, "done": bool(t.done), "x": x, "y": y, "z": z}
        if isinstance(t, BrickTask):
            attrs["brick"] = t.brick
        else:
            attrs.update(below=t.below, above=t.above, length=t.length_m)
        g.add_node(t.id, **attrs)
    for u, v in plan.dependencies:
        g.add_edge(u, v, relation="dependency")
    for a, b in plan.conflicts:
        g.add_edge(a, b, relation="conflict")
    return g


def graph_dot(plan: Plan, *, title: str | None = None) -> str:
    """Graphviz DOT text of G^d (solid arrows, u -> v: u waits for v) and G^c (dashed, undirected)."""
    lines = ["digraph plan {", "  rankdir=TB;", '  node [fontname="Helvetica", fontsize=10];']
    if title:
        lines.append(f"  label={_q(title)}; labelloc=t;")
    for t in plan.tasks:
        shape = "box" if t.kind == "brick" else "ellipse"
        if t.done:
            style = f'style=filled, fillcolor="{DONE_COLOUR}", label={_q(t.id + " (done)")}'
        else:
            style = f'style=filled, fillcolor="{KIND_COLOURS[t.kind]}", fontcolor=white'
        lines.append(f"  {_q(t.id)} [shape={shape}, {style}];")
    for u, v in plan.dependencies:
        lines.append(f"  {_q(u)} -> {_q(v)};")
    for a, b in plan.conflicts:
        lines.append(
            f'  {_q(a)} -> {_q(b)} [dir=none, style=dashed, color="{CONFLICT_COLOUR}", constraint=false];'
        )
    lines.append("}")
    return "\n".join(lines) + "\n"


def _q(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def layout(plan: Plan) -> dict[str, tuple[float, float]]:
    """Drawing position of each task: (position along the wall's main horizontal axis, height level)."""
    if not plan.tasks:
        return {}
    loc = np.array([_location(t) for t in plan.tasks], dtype=float)
    xy = loc[:, :2] - loc[:, :2].mean(axis=0)
    if len(xy) > 1 and np.ptp(xy, axis=0).max() > 0:
        _, _, vt = np.linalg.svd(xy, full_matrices=False)
        axis = vt[0] if vt[0][np.argmax(np.abs(vt[0]))] > 0 else -vt[0]
    else:
        axis = np.array([1.0, 0.0])
    along = xy @ axis
    levels = np.unique(np.round(loc[:, 2], 6))
    level = np.searchsorted(levels, np.round(loc[:, 2], 6))
    span = max(float(np.ptp(along)), 1e-9)
    scale = max(len(levels) - 1, 1) * 1.6 / span  # keep the aspect readable: width ~ 1.6 x height
    return {t.id: (float(along[k] * scale), float(level[k])) for k, t in enumerate(plan.tasks)}


def draw_graphs(plan: Plan, path: str | Path, *, title: str | None = None) -> Path:
    """Draw G^d and G^c together with matplotlib to a .png or .svg file."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    path = Path(path)
    pos = layout(plan)
    n = len(plan.tasks)
    labels = n <= LABEL_LIMIT
    levels = max((p[1] for p in pos.values()), default=0.0)
    width = max((p[0] for p in pos.values()), default=0.0) - min((p[0] for p in pos.values()), default=0.0)
    fig, ax = plt.subplots(
        figsize=(min(24.0, max(6.0, 2.0 + width * 1.2)), min(18.0, max(4.0, 1.5 + levels * 0.9)))
    )
    index = {t.id: k for k, t in enumerate(plan.tasks)}
    xy = np.array([pos[t.id] for t in plan.tasks], dtype=float).reshape(-1, 2)
    # G^c: every pair when it is drawable, else an evenly spaced sample (said so in the title).
    if plan.conflict_indices is not None and len(plan.conflict_indices[0]) == len(plan.conflicts):
        ca, cb = (np.asarray(v, dtype=np.int64) for v in plan.conflict_indices)
    else:
        ca = np.array([index[a] for a, _ in plan.conflicts], dtype=np.int64)
        cb = np.array([index[b] for _, b in plan.conflicts], dtype=np.int64)
    drawn = len(ca)
    if drawn > MAX_DRAWN_CONFLICTS:
        pick = np.linspace(0, len(ca) - 1, MAX_DRAWN_CONFLICTS).astype(np.int64)
        ca, cb = ca[pick], cb[pick]
        drawn = MAX_DRAWN_CONFLICTS
    if drawn:
        dense = drawn > 100 or not labels
        ax.add_collection(
            # an (N, 2, 2) array is what LineCollection draws; its stub only names a Sequence of segments
            LineCollection(
                np.stack([xy[ca], xy[cb]], axis=1),  # type: ignore[arg-type]
                colors=CONFLICT_COLOUR,
                linestyles="solid" if drawn > 2000 else "dashed",  # dashes cost minutes when dense
                linewidths=0.4 if dense else 0.9,
                alpha=0.2 if dense else 0.8,
                zorder=1,
            )
        )
    if labels:
        for u, v in plan.dependencies:
            ax.annotate(
                "",
                xy=pos[v],
                xytext=pos[u],
                zorder=2,
                arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.0, "shrinkA": 11, "shrinkB": 11},
            )
    elif plan.dependencies:
        du = np.array([index[u] for u, _ in plan.dependencies], dtype=np.int64)
        dv = np.array([index[v] for _, v in plan.dependencies], dtype=np.int64)
        segments = np.stack([xy[du], xy[dv]], axis=1)
        ax.add_collection(LineCollection(segments, colors="black", linewidths=0.4, zorder=2))  # type: ignore[arg-type]
    size = 600 if labels else max(4.0, 6000.0 / max(n, 1))
    for kind in ("brick", "adhesion"):
        for done in (False, True):
            members = [k for k, t in enumerate(plan.tasks) if t.kind == kind and bool(t.done) == done]
            if members:
                ax.scatter(
                    xy[members, 0],
                    xy[members, 1],
                    s=size,
                    marker="s" if kind == "brick" else "o",
                    c=DONE_COLOUR if done else KIND_COLOURS[kind],
                    edgecolors="black",
                    linewidths=0.6 if labels else 0.0,
                    zorder=3,
                )
    if labels:
        for task in plan.tasks:
            x, y = pos[task.id]
            text = task.id + (" \u2713" if task.done else "")
            ax.text(
                x,
                y,
                text,
                ha="center",
                va="center",
                fontsize=7,
                zorder=4,
                color="black" if task.done else "white",
            )
    ax.legend(
        handles=[
            Line2D(
                [],
                [],
                marker="s",
                linestyle="",
                color=KIND_COLOURS["brick"],
                markersize=9,
                label="brick task",
            ),
            Line2D(
                [],
                [],
                marker="o",
                linestyle="",
                color=KIND_COLOURS["adhesion"],
                markersize=9,
                label="adhesion task",
            ),
            Line2D([], [], marker="s", linestyle="", color=DONE_COLOUR, markersize=9, label="done (placed)"),
            Line2D([], [], color="black", label="dependency (waits for)"),
            Line2D([], [], color=CONFLICT_COLOUR, linestyle="dashed", label="conflict"),
        ],
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
    )
    heading = title or "dependency graph G^d and conflict graph G^c"
    if drawn < len(plan.conflicts):
        heading += f"\n(conflicts: {drawn:,} of {len(plan.conflicts):,} drawn)"
    ax.set_title(heading)
    ax.set_ylabel("height level")
    ax.set_xticks([])
    ax.set_yticks(sorted({int(p[1]) for p in pos.values()}) if labels else [])
    ax.margins(0.12)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=150 if path.suffix.lower() == ".png" else None)
    plt.close(fig)
    return path


__all__ = ["AdhesionTask", "draw_graphs", "export_graphs", "graph_dot", "layout", "plan_graph"]
