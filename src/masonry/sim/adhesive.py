"""Adhesive deposited by an adhesion UAV: a polyline of bead segments on the surfaces it sprayed over.

While the valve is open and the nozzle is within ``spray_max_height_m`` of the surface below it, each world
step adds the segment the nozzle's ground projection travelled (on that surface). The coverage of an adhesion
segment is the fraction of its length (sampled every ``sample_m``) that lies within ``bead_radius_m``
horizontally of some deposit at about the same height (``z_tolerance_m``, less than a course, so glue on the
wrong course does not count).
"""

from __future__ import annotations

import math

import numpy as np

from masonry.sim.bricks import SpatialHash

__all__ = ["AdhesiveDeposit"]

Vec3 = tuple[float, float, float]


class AdhesiveDeposit:
    """Every bead segment deposited in a world, indexed for coverage queries."""

    def __init__(
        self,
        *,
        bead_radius_m: float = 0.03,
        z_tolerance_m: float = 0.05,
        sample_m: float = 0.005,
        cell_m: float = 0.25,
    ) -> None:
        self.bead_radius_m = float(bead_radius_m)
        self.z_tolerance_m = float(z_tolerance_m)
        self.sample_m = float(sample_m)
        self._segments: list[tuple[float, float, float, float, float, float]] = []
        self._times: list[float] = []  # when each bead segment was laid (s, the world's clock)
        self._hash = SpatialHash(cell_m)
        self.length_m = 0.0

    def __len__(self) -> int:
        return len(self._segments)

    def add(self, p0: Vec3, p1: Vec3, time_s: float = 0.0) -> None:
        """A bead from ``p0`` to ``p1`` (points on the surface; equal points make a dot), laid at ``time_s``."""
        key = len(self._segments)
        self._segments.append((p0[0], p0[1], p0[2], p1[0], p1[1], p1[2]))
        self._times.append(float(time_s))
        r = self.bead_radius_m
        self._hash.insert(
            key, min(p0[0], p1[0]) - r, min(p0[1], p1[1]) - r, max(p0[0], p1[0]) + r, max(p0[1], p1[1]) + r
        )
        self.length_m += math.dist(p0[:2], p1[:2])

    def segments_m(self) -> np.ndarray:
        """All bead segments as an (n, 2, 3) array (start, end)."""
        if not self._segments:
            return np.zeros((0, 2, 3))
        return np.asarray(self._segments, dtype=float).reshape(-1, 2, 3)

    def coverage(self, start_m: Vec3, end_m: Vec3) -> float:
        """Fraction of the segment ``start_m`` -> ``end_m`` within the bead radius of deposited adhesive."""
        covered, _ = self._covering(start_m, end_m)
        return float(np.mean(covered.any(axis=1))) if covered.size else 0.0

    def laid_at_s(self, start_m: Vec3, end_m: Vec3) -> float | None:
        """When the glue on the segment ``start_m`` -> ``end_m`` was laid: per sample the freshest bead over it,
        the oldest of those (a re-sprayed stretch counts as fresh); None: no glue on it."""
        covered, keys = self._covering(start_m, end_m)
        if not covered.size or not covered.any():
            return None
        times = np.asarray([self._times[k] for k in keys], dtype=float)
        fresh = np.where(covered, times[None, :], -np.inf).max(axis=1)
        return float(fresh[np.isfinite(fresh)].min())

    def _covering(self, start_m: Vec3, end_m: Vec3) -> tuple[np.ndarray, list[int]]:
        """(samples x candidate beads) booleans: the bead covers the sample; and the candidates' keys."""
        a = np.asarray(start_m, dtype=float)
        b = np.asarray(end_m, dtype=float)
        length = float(np.linalg.norm((b - a)[:2]))
        n = max(2, math.ceil(length / self.sample_m) + 1)
        t = np.linspace(0.0, 1.0, n)
        samples = a[None, :] + t[:, None] * (b - a)[None, :]
        r = self.bead_radius_m
        keys = self._hash.query(
            float(samples[:, 0].min()) - r,
            float(samples[:, 1].min()) - r,
            float(samples[:, 0].max()) + r,
            float(samples[:, 1].max()) + r,
        )
        if not keys:
            return np.zeros((0, 0), dtype=bool), []
        ordered = sorted(keys)
        seg = np.asarray([self._segments[k] for k in ordered], dtype=float)
        p0, p1 = seg[:, 0:2], seg[:, 3:5]
        z = (seg[:, 2] + seg[:, 5]) / 2.0
        d = p1 - p0
        dd = np.einsum("ij,ij->i", d, d)
        rel = samples[:, None, :2] - p0[None, :, :]  # (n, m, 2)
        u = np.where(dd > 0, np.einsum("nmj,mj->nm", rel, d) / np.where(dd > 0, dd, 1.0), 0.0)
        u = np.clip(u, 0.0, 1.0)
        closest = p0[None, :, :] + u[:, :, None] * d[None, :, :]
        dist2 = np.sum((samples[:, None, :2] - closest) ** 2, axis=2)
        near_z = np.abs(samples[:, None, 2] - z[None, :]) <= self.z_tolerance_m
        return (dist2 <= r * r) & near_z, ordered
