"""3-D plot of a mission: the wall's bricks as boxes and every UAV's flown path."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.blueprint import Blueprint
    from masonry.perception.types import AsBuiltPose


def _box_faces(center: tuple[float, float, float], size: tuple[float, float, float], yaw: float) -> list[Any]:
    hx, hy, hz = (s / 2.0 for s in size)
    c, s = math.cos(yaw), math.sin(yaw)
    corners = []
    for dz in (-hz, hz):
        for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)):
            corners.append((center[0] + c * dx - s * dy, center[1] + s * dx + c * dy, center[2] + dz))
    b, t = corners[:4], corners[4:]
    return [b, t] + [[b[i], b[(i + 1) % 4], t[(i + 1) % 4], t[i]] for i in range(4)]


def _faces(
    blueprint: Blueprint,
    done: set[str],
    seen: Mapping[str, AsBuiltPose],
    tolerance_m: float,
    cmap_dev: Callable[[float], tuple[float, float, float, float]],
) -> tuple[list[object], ...]:
    """The bricks' faces: pre-placed, placed (unseen), not placed, and seen (with their deviation colours)."""
    faces_done: list[object] = []
    faces_pre: list[object] = []
    faces_todo: list[object] = []
    faces_seen: list[object] = []
    colours_seen: list[object] = []
    for b in blueprint.bricks:
        pose = seen.get(f"B{b.id}")
        if pose is not None and not b.placed:
            # drawn where its camera saw it, coloured by its deviation (green on the design, red at the tolerance)
            f = _box_faces(pose.position_m, b.size_m, pose.yaw_rad)
            faces_seen.extend(f)
            colours_seen.extend([cmap_dev(min(1.0, pose.deviation_m / tolerance_m))] * len(f))
            continue
        f = _box_faces(b.position_m, b.size_m, b.yaw_rad)
        if b.placed:
            faces_pre.extend(f)
        elif f"B{b.id}" in done:
            faces_done.extend(f)
        else:
            faces_todo.extend(f)
    return faces_pre, faces_done, faces_todo, faces_seen, colours_seen


def draw_plot3d(blueprint: Any, report: Any, path: str | Path, *, title: str | None = None) -> Path:
    """Draw the wall of ``blueprint`` and the paths in ``report.paths_m`` to ``path`` (.png or .svg).

    Bricks placed during the mission are drawn at their as-built pose (``report.as_built``) and coloured by its
    deviation from the design (green on it, red at the blueprint's ``placement_tolerance_m`` and beyond); placed
    ones without an as-built pose are red, pre-placed ones grey, bricks not placed (mission not completed) are
    outlined only.

    Raises:
        InputError: the file extension is neither .png nor .svg.
    """
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"`plot3d` {path}: the file must end in .png or .svg", options=("plot3d",))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    done = {t.id for t in report.tasks if t.status == "done"}
    seen = getattr(report, "as_built", {}) or {}
    tolerance_m = blueprint.placement.tolerance_m
    cmap_dev = plt.get_cmap("RdYlGn_r")
    fig = plt.figure(figsize=(9, 7))
    ax = fig.add_subplot(projection="3d")
    faces_pre, faces_done, faces_todo, faces_seen, colours_seen = _faces(
        blueprint, done, seen, tolerance_m, cmap_dev
    )
    for faces, colour, alpha in (
        (faces_pre, "#a0a0a0", 0.8),
        (faces_done, "#c0504d", 0.9),
        (faces_todo, "none", 0.2),
        (faces_seen, colours_seen, 0.9),
    ):
        if faces:
            ax.add_collection3d(
                Poly3DCollection(faces, facecolors=colour, edgecolors="black", linewidths=0.2, alpha=alpha)
            )
    if faces_seen:
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        bar = fig.colorbar(
            ScalarMappable(Normalize(0.0, tolerance_m * 100.0), cmap_dev), ax=ax, shrink=0.5, pad=0.1
        )
        bar.set_label("as-built deviation from the design [cm] (red: at the tolerance or beyond)")
    pts = [np.asarray(b.position_m) for b in blueprint.bricks]
    cmap = plt.get_cmap("tab10")
    for i, (name, p) in enumerate(sorted(report.paths_m.items())):
        p = np.asarray(p, dtype=float).reshape(-1, 3)
        if len(p) == 0:
            continue
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=cmap(i % 10), linewidth=0.8, label=name)
        pts.extend(p[[0, -1]])
        pts.extend(p[:: max(1, len(p) // 50)])
    if pts:
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        mid, half = (lo + hi) / 2.0, max(float((hi - lo).max()) / 2.0, 0.5)
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(0.0, max(2.0 * half, hi[2] + 0.2))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    if report.paths_m:
        ax.legend(fontsize=7, loc="upper left")
    ax.set_title(title or f"wall and flown paths ({report.policy}, seed {report.seed})")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
