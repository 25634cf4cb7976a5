"""The airspace's side of waiting near the wall for a task (:mod:`masonry.mission.linger`): where, and who it blocks.

A UAV whose flight home is held back (``ColumnClearance.lingering``) is sent a hold flight to a spot near where
it asked (:func:`linger_spans`, :func:`linger_spots`): clear of every site still to be worked and of every
adhesion segment along its whole length, of the pads, and of what the others hold. (Who it blocks, and so when
it yields: :func:`masonry.mission.linger.held_up_by`.) Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission.volumes import XY, Vec3, point_segment_m

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["linger_spans", "linger_spots"]


def linger_spans(c: ColumnClearance, uav: str, site: Vec3) -> tuple[tuple[XY, XY], ...] | None:
    """What ``uav``'s hold point keeps clear of while it waits near the wall (None: it does not wait there)."""
    if not c.is_home(uav, site):
        return None
    return c.lingering.get(uav)


def linger_spots(
    c: ColumnClearance, uav: str, start: Vec3, candidates: list[Vec3], keep_clear: tuple[tuple[XY, XY], ...]
) -> list[Vec3]:
    """The hold points where a UAV waiting for a task may wait: nearer than its home (else it may as well land
    there), and ``1.1 wait_radius_m`` clear of every site and segment still to be worked (:func:`hold_candidates`
    falls back on a far point that need not be)."""
    home = c.homes.get(uav)
    if home is None:
        return []
    far_m = math.hypot(home[0] - start[0], home[1] - start[1])
    r = 1.1 * c.wait_radius_m - 1e-9
    return [
        h
        for h in candidates
        if math.hypot(h[0] - start[0], h[1] - start[1]) < far_m
        and all(point_segment_m((h[0], h[1]), a, b) >= r for a, b in keep_clear)
    ]
