"""The as-built pose relative to the wall (issue 30): the placed brick's offset from a neighbour seen in the same frames.

The as-built look (:mod:`masonry.fsm.as_built`) places the camera's view in the world with the telemetry of the
tick, so its pose carries the position source's error at that moment: on GNSS (the ``px4`` model) the wander,
5 cm per axis, which no averaging over a climb removes (it moves on over seconds, not frames). A brick already on
the wall seen in the *same* frame is placed by the same telemetry: the difference of the two estimates, the placed
brick's top-face centre less the neighbour's, holds no position error at all (only the attitude's, which turns a
vector of a few decimetres by a fraction of a degree). Over the frames of the climb each neighbour seen with the
placed brick gathers these offsets in a :class:`~masonry.perception.estimation.PoseWindow` (the paper's filter:
their mean, and its confidence C); at the end every neighbour seen in two frames or more is reported with its
offset and its number of frames (mission control combines them over the wall), and the neighbour seen most (ties:
the nearest in the design, its support or course neighbour) is the reference. Anchored to that neighbour's designed
top-face centre, the offset's distance from the designed offset is the brick's deviation from the design *relative
to the wall*: how far off its designed offset to the brick beside or under it the brick was built, which the glue
joint takes, measured to camera noise.

A brick counts as on the wall when it is seen within ``REFERENCE_M`` of its design, as for the wall alignment
(:mod:`masonry.fsm.wall_align`): a brick on the pallet or on another UAV's magnet is no reference. A blueprint
that reuses marker numbers has no ``UavConfig.wall`` (a number names no single brick): no relative pose there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from masonry.perception.estimation import PoseWindow

__all__ = ["REFERENCE_M", "RelativeLook", "RelativePose"]

#: A brick seen farther than this from its design is not on the wall (a pallet, a magnet): no reference.
REFERENCE_M = 0.5


@dataclass(frozen=True)
class RelativePose:
    """The placed brick against one neighbour: ``relative_to`` (its brick id), ``offset_m`` (the placed brick's
    top-face centre less the neighbour's, world axes, m), ``deviation_m`` (the offset's distance from the designed
    one, m) and ``frames`` (the frames that saw both)."""

    relative_to: int
    offset_m: tuple[float, float, float]
    deviation_m: float
    frames: int


class RelativeLook:
    """Per neighbour seen with the placed brick, the window of the placed brick's offsets from it.

    Args:
        window_size: offsets kept per neighbour (the first ones: the nearest frames of the climb).
        sigma_tol_m: the confidence's tolerance (the paper's sigma_tol).
    """

    def __init__(self, window_size: int, sigma_tol_m: float) -> None:
        self.window_size = window_size
        self.sigma_tol_m = sigma_tol_m
        self.windows: dict[int, PoseWindow] = {}
        self._wall_key: tuple[tuple[int, tuple[float, ...]], ...] | None = None
        self._wall: dict[int, np.ndarray] = {}

    def begin(self) -> None:
        """A new placement: forget the last brick's offsets."""
        self.windows.clear()

    def wall(self, wall: tuple[tuple[int, tuple[float, ...]], ...]) -> Mapping[int, np.ndarray]:
        """``UavConfig.wall`` as brick id -> designed top-face centre (made once per wall)."""
        if wall is not self._wall_key:
            self._wall_key = wall
            self._wall = {bid: np.asarray(top, dtype=float) for bid, top in wall}
        return self._wall

    def add(
        self, own: int, own_top_m: np.ndarray, seen: Mapping[int, np.ndarray], wall: Mapping[int, np.ndarray]
    ) -> None:
        """One frame in which brick ``own`` was seen at ``own_top_m`` with the bricks ``seen`` (brick id -> top-face
        centre; all in the world frame from the same telemetry): the offset from each brick on the wall among them
        joins that brick's window."""
        for bid, top in seen.items():
            design = wall.get(bid)
            if bid == own or design is None or float(np.linalg.norm(top - design)) > REFERENCE_M:
                continue
            window = self.windows.get(bid)
            if window is None:
                window = self.windows[bid] = PoseWindow(size=self.window_size, sigma_tol_m=self.sigma_tol_m)
            if window.count < self.window_size:
                window.add(own_top_m - top, 0.0)

    def pose(self, own: int, wall: Mapping[int, np.ndarray]) -> RelativePose | None:
        """The offset from the neighbour seen most (ties: the nearest in the design); None when no neighbour was
        seen in two frames with the placed brick, or the wall has no design for it."""
        own_design = wall.get(own)
        if own_design is None:
            return None
        seen = [(w.count, bid) for bid, w in self.windows.items() if w.count >= 2]
        if not seen:
            return None
        _, bid = min(seen, key=lambda s: (-s[0], float(np.linalg.norm(wall[s[1]] - own_design)), s[1]))
        return self._relative(bid, own_design, wall)

    def poses(self, own: int, wall: Mapping[int, np.ndarray]) -> tuple[RelativePose, ...]:
        """The offsets from every neighbour seen in two frames or more with the placed brick, by brick id (what
        mission control combines over the wall, :mod:`masonry.planner.wall_solve`); () as :meth:`pose`'s None."""
        own_design = wall.get(own)
        if own_design is None:
            return ()
        return tuple(
            self._relative(bid, own_design, wall)
            for bid in sorted(self.windows)
            if self.windows[bid].count >= 2
        )

    def _relative(self, bid: int, own_design: np.ndarray, wall: Mapping[int, np.ndarray]) -> RelativePose:
        offset, _ = self.windows[bid].mean()
        designed = own_design - wall[bid]
        x, y, z = (float(v) for v in offset)
        return RelativePose(bid, (x, y, z), math.dist((x, y, z), designed.tolist()), self.windows[bid].count)
