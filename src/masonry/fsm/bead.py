"""A spray pass measured by the nozzle (issue 18): the bead's reference point, the valve, what the nozzle covered.

The adhesion UAV sprays a segment by moving a reference point for its nozzle along it at the spray speed (never
more than ``lead_m`` ahead of the nozzle: a head gust does not leave it behind). The valve is open only while the
nozzle (its position from the UAV's own telemetry: the body position, the lever arm and the tilt) is within
``valve_radius_m`` of the segment and within the spray's reach of the surface: a gust that pushes it off the
bead closes the valve instead of gluing beside the bead. Each tick the nozzle's movement with the valve open marks
the segment's samples (every ``sample_m``) within ``check_radius_m`` of it as covered: the UAV's own measure of
its bead. A pass is over when no sample is left uncovered ahead of the reference (or its end has been held for
``end_wait_s``); with gaps left behind, the next pass goes back over them and ends past the last one.

Pure: no ports, no clock; the model feeds it the nozzle's position each tick and flies its reference.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class BeadSettings:
    """How a pass is flown and measured (metres, seconds, m/s).

    Attributes:
        speed_mps: the reference's speed along the segment.
        valve_radius_m: the valve is open only while the nozzle is this close to the segment (horizontally;
            the simulator's bead radius is 3 cm).
        check_radius_m: a sample of the segment is covered once the sprayed nozzle track passed this close.
        lead_m: the reference runs at most this far ahead of the nozzle along the segment (an autopilot's delay
            makes the nozzle trail it by speed x delay: 9 cm at 0.15 m/s behind ArduCopter's 0.57 s).
        end_wait_s: a pass whose reference has reached the end is over after this, covered there or not.
        sample_m: the spacing of the segment's samples.
    """

    speed_mps: float
    valve_radius_m: float = 0.03
    check_radius_m: float = 0.02
    lead_m: float = 0.12
    end_wait_s: float = 2.0
    sample_m: float = 0.01


class BeadStep(NamedTuple):
    """One tick of a pass: where the nozzle should be, how fast the reference moves, the valve, the pass over."""

    nozzle_ref_m: Vec3
    velocity_mps: Vec3
    valve_open: bool
    pass_over: bool


class BeadPass:
    """The passes over one segment ``start_m -> end_m`` (points on the surface, world ENU).

    Attributes:
        passes: passes begun (1 at the start: towards ``end_m``; even ones back towards ``start_m``).
        progress_m: the reference's distance from ``start_m`` along the segment (horizontally).
    """

    def __init__(self, start_m: Sequence[float], end_m: Sequence[float], settings: BeadSettings) -> None:
        self.settings = settings
        self._a = np.asarray(start_m, dtype=float)
        d = np.asarray(end_m, dtype=float) - self._a
        self.length_m = float(np.linalg.norm(d[:2]))
        self._per_m = d / max(self.length_m, 1e-9)  # the segment's change per horizontal metre
        self._unit_xy = d[:2] / max(self.length_m, 1e-9)
        n = max(2, math.ceil(self.length_m / settings.sample_m) + 1)
        self._samples_s = np.linspace(0.0, self.length_m, n)
        self._samples_xy = self._a[None, :2] + self._samples_s[:, None] * self._unit_xy[None, :]
        self._covered = np.zeros(n, dtype=bool)
        self._last_xy: np.ndarray | None = None  # the nozzle at the last tick, if the valve opened there
        self._valve_was_open = False
        self._at_end_s = 0.0  # how long this pass's reference has been at its end
        self.passes = 1
        self.progress_m = 0.0

    @property
    def direction(self) -> int:
        """+1 towards ``end_m`` (odd passes), -1 back towards ``start_m``."""
        return 1 if self.passes % 2 == 1 else -1

    def point_m(self, s_m: float) -> np.ndarray:
        """The segment's point ``s_m`` (horizontal metres) from its start."""
        point: np.ndarray = self._a + self._per_m * s_m
        return point

    def coverage(self) -> float:
        """The fraction of the segment's samples the sprayed nozzle track covered."""
        return float(np.mean(self._covered))

    def gaps_ahead(self) -> bool:
        """Samples not covered yet from the reference to the end of this pass."""
        if self.direction > 0:
            ahead = self._samples_s >= self.progress_m - 1e-9
        else:
            ahead = self._samples_s <= self.progress_m + 1e-9
        return bool(np.any(~self._covered & ahead))

    def turn(self) -> None:
        """Begin the next pass, back along the segment from where the reference is."""
        self.passes += 1
        self._at_end_s = 0.0

    def _along_across_m(self, xy: np.ndarray) -> tuple[float, float]:
        rel = xy - self._a[:2]
        along = float(rel @ self._unit_xy)
        across = float(abs(rel[0] * self._unit_xy[1] - rel[1] * self._unit_xy[0]))
        return along, across

    def _mark(self, p0: np.ndarray, p1: np.ndarray) -> None:
        """Mark the samples within ``check_radius_m`` of the nozzle's movement ``p0 -> p1``."""
        d = p1 - p0
        dd = float(d @ d)
        rel = self._samples_xy - p0[None, :]
        u = np.clip(rel @ d / dd, 0.0, 1.0) if dd > 0.0 else np.zeros(len(rel))
        closest = p0[None, :] + u[:, None] * d[None, :]
        r = self.settings.check_radius_m
        self._covered |= np.sum((self._samples_xy - closest) ** 2, axis=1) <= r * r

    def step(self, dt_s: float, nozzle_m: Sequence[float] | np.ndarray, in_reach: bool) -> BeadStep:
        """One tick: the nozzle at ``nozzle_m`` (measured; ``in_reach``: low enough to spray the surface).

        Marks what it covered since the last tick (the valve open since then, and the surface still in reach),
        moves the
        reference on, and says where the nozzle should be, whether the valve is open and whether this pass is
        over.
        """
        cfg = self.settings
        xy = np.asarray(nozzle_m[:2], dtype=float)
        along, across = self._along_across_m(xy)
        on_bead = (
            in_reach
            and across <= cfg.valve_radius_m
            and -cfg.valve_radius_m <= along <= self.length_m + cfg.valve_radius_m
        )
        if self._last_xy is not None and in_reach:
            self._mark(
                self._last_xy, xy
            )  # sprayed since the last tick: the valve was open, and still reaches
        # counted from the tick after the valve opened: what it sprays in its first tick (the valve's and the
        # adhesive's delay) starts somewhere on the way, not where the nozzle was when it opened
        self._last_xy = xy if on_bead and self._valve_was_open else None
        self._valve_was_open = on_bead
        d = self.direction
        end_m = self.length_m if d > 0 else 0.0
        to_end_m = abs(end_m - self.progress_m)
        moving = False
        if to_end_m > 1e-9 and (self.progress_m - along) * d < cfg.lead_m:
            self.progress_m += d * min(cfg.speed_mps * dt_s, to_end_m)
            moving = abs(end_m - self.progress_m) > 1e-9
        elif to_end_m <= 1e-9:
            self._at_end_s += dt_s
        ref = self.point_m(self.progress_m)
        # over: nothing left to cover ahead; or at the end with the nozzle past it (a gust carried it over: what is
        # left is behind it, for the next pass) or, at the latest, after end_wait_s there
        past = (along - end_m) * d >= 0.0
        to_end_m = abs(end_m - self.progress_m)
        over = not self.gaps_ahead() or (to_end_m <= 1e-9 and (past or self._at_end_s >= cfg.end_wait_s))
        v = self._per_m * (d * cfg.speed_mps) if moving else np.zeros(3)
        return BeadStep(
            (float(ref[0]), float(ref[1]), float(ref[2])),
            (float(v[0]), float(v[1]), float(v[2])),
            on_bead,
            over,
        )
