"""Airspace separation between UAVs: transit layers (static) and site columns (mission control, at run time).

The paper's conflict graph G^c keeps the task *locations* (drop-off points, adhesion segments) r_c apart; it
says nothing about the flights between them nor about the shared pickup pallet. Two mechanisms close that gap
(docs/safety.md):

- **Transit layers**: every UAV flies its lateral legs (between pickup, drop-off, segment and home) at its own
  altitude, ``base + (k + 1) * spacing`` for the k-th UAV of the fleet, where ``base`` is the highest altitude
  at which any task of the wall is worked (:func:`work_altitude_m`). Lateral legs of two UAVs are therefore
  at least ``spacing`` apart vertically, and above every UAV working at a site. The state machines climb to the
  layer before a lateral leg and descend after it (vertically, never diagonally).
- **Site columns**: leaving the layer at a site (to pick up, place, spray, or land at home) needs a clearance
  from mission control for a vertical *column* there. :class:`ColumnClearance` grants columns first come, first
  served, never two within ``radius_m`` (horizontally) of each other; the UAV hovers at its layer until granted
  and frees its column once it is ``radius_m`` away from it (or has landed). Mission control runs it, so it
  works the same in-process and across Zenoh (messages ``clearance-request`` / ``clearance``).

Everything here is pure (no I/O, no clock).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from masonry.blueprint import Blueprint, UavSpec

Vec3 = tuple[float, float, float]
XY = tuple[float, float]

#: Vertical distance between two transit layers: the 1 m separation target plus tracking error and gusts.
DEFAULT_LAYER_SPACING_M = 1.1


def work_altitude_m(blueprint: Blueprint) -> float:
    """The highest altitude at which a UAV works any task of ``blueprint`` (cruise altitude at least).

    The same formulas as the state machines' site altitudes (``masonry.fsm``, defaults of ``UavConfig``): a brick
    UAV keeps the carried brick ``clearance_m`` above the drop-off, an adhesion UAV its nozzle ``clearance_m``
    above the spraying height.
    """
    from masonry.fsm.config import UavConfig

    cfg = UavConfig(name="-", role="brick", home_m=(0.0, 0.0, 0.0))
    eff_z = cfg.airframe.effector_offset_m[2]
    nozzle_z = cfg.airframe.nozzle_offset_m[2]
    z = float(blueprint.cruise_altitude_m)
    for b in blueprint.bricks:
        size_z = float(b.size_m[2])
        top = float(b.position_m[2]) + size_z / 2.0
        z = max(z, top - eff_z + size_z + cfg.clearance_m)
        z = max(z, top + cfg.airframe.spray_height_m - nozzle_z + cfg.clearance_m)
    return z


#: Average vertical speed of a climb to a layer (``masonry.fsm.UavConfig.layer_vertical_speed_mps``).
CLIMB_SPEED_MPS = 0.5

#: Layer 0 starts this far above the highest work altitude (the spacing of the layers above it has its own
#: margin over the separation target).
LAYER_MARGIN_M = 0.0


def layer_base_m(blueprint: Blueprint) -> float:
    """Altitude of transit layer 0 for ``blueprint``: :func:`work_altitude_m` plus :data:`LAYER_MARGIN_M`."""
    return work_altitude_m(blueprint) + LAYER_MARGIN_M


def transit_layers_m(
    blueprint: Blueprint,
    fleet: Sequence[UavSpec] | None = None,
    spacing_m: float = DEFAULT_LAYER_SPACING_M,
) -> dict[str, float]:
    """Altitude of each UAV's lateral legs: ``work_altitude_m + (k + 1) * spacing_m``, k its index in ``fleet``.

    ``fleet`` defaults to the blueprint's. A UAV flying its own mission process (``masonry fly --mission``) gets
    the same layer as in ``masonry sim``, because both number the blueprint's fleet the same way.
    """
    if not (spacing_m >= 0.0 and math.isfinite(spacing_m)):
        raise ValueError(f"layer spacing must be a finite number >= 0, got {spacing_m!r}")
    members = tuple(blueprint.fleet if fleet is None else fleet)
    base = layer_base_m(blueprint)
    return {u.name: base + (k + 1) * spacing_m for k, u in enumerate(members)}


@dataclass(frozen=True)
class Grant:
    """Mission control's answer to a UAV setting off for ``site_m``.

    ``layer_m``: the altitude of its lateral leg (None: no layers, fly as you like). ``granted`` True: the column
    over the site is the UAV's, go down there. False: fly (at ``layer_m``) to ``hold_m``, a point outside every
    column held, wait there and ask again.
    """

    uav: str
    site_m: Vec3
    granted: bool = True
    hold_m: Vec3 | None = None
    layer_m: float | None = None


class ColumnClearance:
    """The airspace at run time: site columns, first come first served, and transit layers handed out per flight.

    - **Columns**: never two within ``radius_m`` (horizontally) of each other. A UAV asks for the column of its
      next site when it sets off (``request``) and keeps the columns it holds until it has left them
      (``release``, sent by its handler once ``radius_m`` away, or on landing).
    - **Layers**: each flight gets an altitude for its lateral leg, held until the flight has come down at its
      site (``end_transit``). Layer 0 is ``base_m`` (just above the work altitude): given only when the straight
      path keeps ``path_clearance_m`` from every other column, layer-0 path, and point where another flight
      climbs or descends, so such a flight meets nobody. Otherwise the lowest layer ``base_m + k * spacing_m``
      (k >= 1) that no other flight in progress uses and on which it crosses no other flight: lateral legs of
      two flights are ``spacing_m`` apart vertically, and above everyone working at a site.
    - A request whose column is taken is answered with a hold point outside every held column and other hold
      point: the UAV waits there at its layer, so nobody climbs or descends through it; since every waiting UAV
      leaves the columns it held, no two UAVs can wait for each other for ever.

    Args:
        radius_m: horizontal distance within which two columns exclude each other.
        base_m: altitude of layer 0 (None: no layers are handed out).
        spacing_m: vertical distance between layers.
        homes: each UAV's home: a UAV takes off there without asking (up to the work altitude), so layer-0
            paths keep clear of the other UAVs' homes.
    """

    def __init__(self, radius_m: float, base_m: float | None = None,
                 spacing_m: float = DEFAULT_LAYER_SPACING_M, homes: Mapping[str, Vec3] | None = None) -> None:
        if not (radius_m >= 0.0 and math.isfinite(radius_m)):
            raise ValueError(f"column radius must be a finite number >= 0, got {radius_m!r}")
        if not (spacing_m > 0.0 and math.isfinite(spacing_m)):
            raise ValueError(f"layer spacing must be a finite number > 0, got {spacing_m!r}")
        self.radius_m = float(radius_m)
        self.base_m = None if base_m is None else float(base_m)
        self.spacing_m = float(spacing_m)
        self._held: dict[str, list[Vec3]] = {}
        # uav -> (site, position when asking, requested at, hold point); insertion order = FIFO
        self._waiting: dict[str, tuple[Vec3, Vec3 | None, float, Vec3 | None]] = {}
        # uav -> (layer index, path segments, points where it climbs or descends) of its flight in progress
        self._transit: dict[str, tuple[int, list[tuple[XY, XY]], list[XY]]] = {}
        self.refused = 0  # requests answered "wait where you are": no layer fits
        #: a layer-0 path keeps this far from other columns and layer-0 paths (a UAV working in its column stays
        #: within a few centimetres of its site, so the separation plus a margin is enough; columns keep radius_m)
        self.path_clearance_m = 1.2
        #: a flight held back this long (it would cross another) goes anyway: liveness over a rare near miss
        self.max_refusal_s = 30.0
        self.forced = 0
        self._refused_since: dict[str, tuple[XY | None, float]] = {}
        self._climb_until: dict[str, float] = {}
        self._hover: dict[str, Vec3] = {}  # UAVs held back, hovering where they asked (kept clear of)
        self._now_s = 0.0
        self.granted_count = 0
        self.held_back = 0  # requests not granted at once
        self.wait_s = 0.0  # summed time between request and grant
        self.max_wait_s = 0.0
        self.layer_counts: dict[int, int] = {}  # flights per layer index
        self._homes: dict[str, XY] = {u: (float(h[0]), float(h[1])) for u, h in (homes or {}).items()}

    @property
    def release_radius_m(self) -> float:
        """A UAV frees a column once this far from it: then nobody descending nearby meets it (the flights are
        checked against each other), so the separation plus a margin is enough."""
        return min(self.radius_m, self.path_clearance_m)

    @property
    def held(self) -> dict[str, tuple[Vec3, ...]]:
        """UAV -> the sites of the columns it holds."""
        return {u: tuple(s) for u, s in self._held.items() if s}

    @property
    def waiting(self) -> tuple[str, ...]:
        """UAVs waiting for a column, in request order."""
        return tuple(self._waiting)

    @property
    def layers(self) -> dict[str, int]:
        """UAV -> layer index of its flight in progress."""
        return {u: t[0] for u, t in self._transit.items()}

    def layer_m(self, uav: str) -> float | None:
        """Altitude of ``uav``'s flight in progress (None: none, or no layers)."""
        t = self._transit.get(uav)
        if t is None or self.base_m is None:
            return None
        return self.base_m + t[0] * self.spacing_m

    def request(self, uav: str, site_m: Vec3, now_s: float, position_m: Vec3 | None = None) -> Grant:
        """``uav`` (now at ``position_m``) sets off for ``site_m``: a layer, and the column or a hold point.

        A repeated request (same site) gets the same answer and keeps its place in the queue; one for another
        site replaces the UAV's pending one and ends its previous flight.
        """
        self._now_s = now_s
        site = (float(site_m[0]), float(site_m[1]), float(site_m[2]))
        origin = (float(position_m[0]), float(position_m[1])) if position_m is not None else (site[0], site[1])
        target = (site[0], site[1])
        if any(self._same(h, site) for h in self._held.get(uav, ())):
            # its own column already (a repeated request, or back to a site it has not left): a flight there
            if uav not in self._transit and not self._fly(uav, [(origin, target)], [origin, target], low_ok=True,
                                                          now_s=now_s, site=site, position_m=position_m):
                return Grant(uav, site, False)
            return Grant(uav, site, layer_m=self.layer_m(uav))
        pending = self._waiting.get(uav)
        if pending is not None and self._same(pending[0], site):
            return Grant(uav, site, False, pending[3], self.layer_m(uav))
        self._waiting.pop(uav, None)
        self._transit.pop(uav, None)
        if not self._blocked(uav, site):
            if not self._fly(uav, [(origin, target)], [origin, target], low_ok=True, now_s=now_s, site=site,
                             position_m=position_m):
                return Grant(uav, site, False)  # it would cross another flight now: wait where you are, ask again
            self._held.setdefault(uav, []).append(site)
            self.granted_count += 1
            return Grant(uav, site, layer_m=self.layer_m(uav))
        hold = self.hold_point(uav, site, position_m)
        hxy = (hold[0], hold[1])
        # to the hold point now; the leg on to the site is checked when the column is granted
        if not self._fly(uav, [(origin, hxy)], [origin], low_ok=False, now_s=now_s, site=site,
                         position_m=position_m):
            return Grant(uav, site, False)
        self._waiting[uav] = (site, position_m, now_s, hold)
        self.held_back += 1
        return Grant(uav, site, False, hold, self.layer_m(uav))

    def end_transit(self, uav: str) -> None:
        """``uav``'s flight came down at its site: its layer is free."""
        self._transit.pop(uav, None)

    def release(self, uav: str, site_m: Vec3 | None = None) -> None:
        """``uav`` left the column over ``site_m`` or gave up asking for it (None: everything: it is out)."""
        if site_m is None:
            self._held.pop(uav, None)
            self._waiting.pop(uav, None)
            self._transit.pop(uav, None)
            self._hover.pop(uav, None)
            return
        held = self._held.get(uav)
        if held:
            held[:] = [h for h in held if not self._same(h, site_m)]
        pending = self._waiting.get(uav)
        if pending is not None and self._same(pending[0], site_m):
            del self._waiting[uav]  # given up before it was granted
            self._transit.pop(uav, None)

    def grant(self, now_s: float) -> list[Grant]:
        """Grant waiting requests, in order, that no other UAV's column (or hold point) blocks any more.

        The UAV keeps the layer it waits at for the rest of its flight.
        """
        self._now_s = now_s
        out: list[Grant] = []
        for uav, (site, _pos, since_s, hold) in list(self._waiting.items()):
            if self._blocked(uav, site):
                continue
            t = self._transit.get(uav)
            if t is not None and hold is not None:
                leg = [((hold[0], hold[1]), (site[0], site[1]))]
                if self._crossing(uav, t[0], leg, [(site[0], site[1])]):
                    first = self._refused_since.setdefault(uav, ((site[0], site[1]), now_s))
                    if now_s - first[1] < self.max_refusal_s:
                        continue  # it would cross a flight still in progress: wait a little longer
                    self.forced += 1
                self._refused_since.pop(uav, None)
                # the UAV may still be on its way to the hold point: keep that leg in its path
                self._transit[uav] = (t[0], t[1] + leg, t[2] + [(site[0], site[1])])
            del self._waiting[uav]
            self._held.setdefault(uav, []).append(site)
            waited = max(0.0, now_s - since_s)
            self.wait_s += waited
            self.max_wait_s = max(self.max_wait_s, waited)
            self.granted_count += 1
            out.append(Grant(uav, site, layer_m=self.layer_m(uav)))
        return out

    def blocking(self, uav: str, site_m: Vec3) -> list[str]:
        """The UAVs whose columns, hold points or layer-0 paths keep ``uav`` from a column over ``site_m``."""
        return [o for o in {**self._held, **self._waiting, **self._transit} if o != uav and self._blocks(o, site_m)]

    def hold_point(self, uav: str, site_m: Vec3, position_m: Vec3 | None) -> Vec3:
        """Where ``uav`` waits for the column over ``site_m``: the point nearest to it that is at least 1.1
        ``radius_m`` from every column held (its own too: it leaves them), other hold points and the sites other
        UAVs wait for.
        """
        keep_out = [h for hs in self._held.values() for h in hs]
        keep_out += [w[3] for o, w in self._waiting.items() if o != uav and w[3] is not None]
        # and the sites others wait for: a hold point there would block them (two UAVs could wait for each other)
        keep_out += [w[0] for o, w in self._waiting.items() if o != uav]
        r = 1.1 * self.radius_m
        r2 = r * r
        origin = position_m if position_m is not None else site_m

        def free(p: tuple[float, float]) -> bool:
            return all((p[0] - k[0]) ** 2 + (p[1] - k[1]) ** 2 >= r2 for k in keep_out)

        if free((origin[0], origin[1])):
            return (float(origin[0]), float(origin[1]), float(site_m[2]))
        best: tuple[float, float] | None = None
        best_d = math.inf
        step = max(self.radius_m, 0.25)
        for ring in range(1, 9):
            for a in range(24):
                ang = 2.0 * math.pi * a / 24.0
                for cx, cy in ((origin[0], origin[1]), (site_m[0], site_m[1])):
                    c = (cx + ring * step * math.cos(ang), cy + ring * step * math.sin(ang))
                    if free(c):
                        d = math.hypot(c[0] - origin[0], c[1] - origin[1])
                        if d < best_d:
                            best, best_d = c, d
            if best is not None:
                break
        if best is None:  # pragma: no cover - eight rings always leave free space around a finite set
            best = (origin[0], origin[1])
        return (float(best[0]), float(best[1]), float(site_m[2]))

    # -- internals --------------------------------------------------------------------------------------------
    def _fly(self, uav: str, path: list[tuple[XY, XY]], vertical: list[XY], *, low_ok: bool,
             now_s: float = 0.0, site: Vec3 | None = None, position_m: Vec3 | None = None) -> bool:
        """Give ``uav`` a layer for a flight along ``path`` that climbs or descends at ``vertical`` points.

        Layer 0 (``base_m``) if allowed and its path keeps clear of every other column, layer-0 path and point
        where a flight in progress climbs or descends: such a flight meets nobody. Otherwise the lowest layer
        above 0 that no other flight in progress uses and on which it crosses nobody: lateral legs of two flights
        above layer 0 are always ``spacing_m`` apart.
        False (no flight) when it would cross another flight in progress (:meth:`_crossing`): the UAV waits where
        it is and asks again; after ``max_refusal_s`` of that it flies anyway (counted in ``forced``). While it
        waits there, other flights keep clear of it.
        """
        if self.base_m is None:
            return True
        if low_ok and self._low_path_clear(uav, path[0][0], path[-1][1]):
            k = 0
        else:
            # the lowest layer above 0 that no other flight in progress uses and on which this one crosses nobody
            used = {t[0] for o, t in self._transit.items() if o != uav}
            top = len(self._transit) + len(self._hover) + 2
            free = [j for j in range(1, top + 1) if j not in used]
            k = next((j for j in free if not self._crossing(uav, j, path, vertical)), free[0])
            if self._crossing(uav, k, path, vertical):
                key = (site[0], site[1]) if site is not None else None
                first = self._refused_since.get(uav)
                if first is None or first[0] != key:
                    self._refused_since[uav] = first = (key, now_s)
                if now_s - first[1] < self.max_refusal_s:
                    self.refused += 1
                    if position_m is not None:
                        self._hover[uav] = (float(position_m[0]), float(position_m[1]), float(position_m[2]))
                    return False
                self.forced += 1
        self._refused_since.pop(uav, None)
        self._hover.pop(uav, None)
        self._transit[uav] = (k, path, vertical)
        # its departure (the first vertical point) counts until it should have climbed to its layer
        self._climb_until[uav] = now_s + 3.0 + 1.875 * (k * self.spacing_m + 0.3) / CLIMB_SPEED_MPS
        self.layer_counts[k] = self.layer_counts.get(k, 0) + 1
        return True

    def _vertical(self, other: str) -> list[XY]:
        """Where a flight in progress still climbs or descends (its departure only until it has climbed)."""
        v = self._transit[other][2]
        return v if self._now_s < self._climb_until.get(other, math.inf) else v[1:]

    def _crossing(self, uav: str, k: int, path: list[tuple[XY, XY]], vertical: list[XY]) -> bool:
        """Would a flight at layer ``k`` along ``path``, climbing or descending at ``vertical``, cross another?

        Yes if a lower flight passes near where it goes through the lower layer, or a higher one climbs or
        descends near its path (within ``path_clearance_m``).
        """
        d = min(self.radius_m, self.path_clearance_m)
        alt = (self.base_m or 0.0) + k * self.spacing_m
        for other, h in self._hover.items():
            if other == uav:
                continue
            if any(_point_segment_m((h[0], h[1]), a, b) < d for a, b in path) and abs(alt - h[2]) < self.spacing_m:
                return True  # it hovers on our way at our altitude
            if any(math.hypot(v[0] - h[0], v[1] - h[1]) < d for v in vertical):
                return True  # we would climb or descend next to it
        for other, (k_o, path_o, _v) in self._transit.items():
            if other == uav or k_o == k:
                continue
            vert_o = self._vertical(other)
            if k_o < k and any(_point_segment_m(v, a, b) < d for v in vertical for a, b in path_o):
                return True
            if k_o > k and any(_point_segment_m(v, a, b) < d for v in vert_o for a, b in path):
                return True
        return False

    def _low_path_clear(self, uav: str, a: XY, b: XY) -> bool:
        r = min(self.radius_m, self.path_clearance_m)
        for other, h in self._hover.items():
            if other != uav and _point_segment_m((h[0], h[1]), a, b) < r:
                return False
        for other, home in self._homes.items():
            if other != uav and _point_segment_m(home, a, b) < r:
                return False
        for other, hs in self._held.items():
            if other != uav:
                for h in hs:
                    if _point_segment_m((h[0], h[1]), a, b) < r:
                        return False
        for other, t in self._transit.items():
            if other == uav:
                continue
            if t[0] == 0 and _segment_segment_m(a, b, t[1][0][0], t[1][-1][1]) < r:
                return False
            if any(_point_segment_m(v, a, b) < r for v in self._vertical(other)):
                return False  # it climbs or descends on our way
        return True

    def _blocks(self, other: str, site: Vec3) -> bool:
        r2 = self.radius_m**2
        for h in self._held.get(other, ()):
            if _d2(h, site) < r2:
                return True
        w = self._waiting.get(other)
        if w is not None and w[3] is not None and _d2(w[3], site) < r2:
            return True
        t = self._transit.get(other)  # a layer-0 flight passing there?
        return t is not None and t[0] == 0 and any(
            _point_segment_m((site[0], site[1]), a, b) < self.release_radius_m for a, b in t[1])

    def _blocked(self, uav: str, site: Vec3) -> bool:
        for other in {**self._held, **self._waiting, **self._transit}:
            if other != uav and self._blocks(other, site):
                return True
        return False

    @staticmethod
    def _same(a: Vec3, b: Vec3) -> bool:
        return math.hypot(a[0] - b[0], a[1] - b[1]) < 1e-3


def _point_segment_m(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """Horizontal distance from ``p`` to the segment ``a``-``b``."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n2 = dx * dx + dy * dy
    t = 0.0 if n2 == 0.0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n2))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


def _segment_segment_m(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
                       d: tuple[float, float]) -> float:
    """Horizontal distance between segments ``a``-``b`` and ``c``-``d``."""
    def orient(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 * o2 < 0.0 and o3 * o4 < 0.0:
        return 0.0  # they cross
    return min(_point_segment_m(c, a, b), _point_segment_m(d, a, b), _point_segment_m(a, c, d),
               _point_segment_m(b, c, d))


def _d2(a: Vec3, b: Vec3) -> float:
    return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2


def min_pairwise_separation_m(points: Iterable[Vec3]) -> float:
    """Smallest distance between two of ``points`` (inf for fewer than two): a helper for tests and reports."""
    pts = list(points)
    best = math.inf
    for i in range(len(pts) - 1):
        for j in range(i + 1, len(pts)):
            best = min(best, math.dist(pts[i], pts[j]))
    return best


__all__ = [
    "CLIMB_SPEED_MPS",
    "DEFAULT_LAYER_SPACING_M",
    "LAYER_MARGIN_M",
    "ColumnClearance",
    "Grant",
    "layer_base_m",
    "min_pairwise_separation_m",
    "transit_layers_m",
    "work_altitude_m",
]
