"""Each airborne UAV against the space-time envelope mission control reserved for it, as the world measures it.

Issue 27 §4.3: safety measured by the world, not by mission control. After each step of the world, every UAV
flying under power (armed, off the ground) is placed, at its true position, against the volumes its airspace
reserves for it at that instant (:class:`ReservedSpace`: the columns' volumes held now, the table's reservations
whose window holds the instant). :class:`EnvelopeWatch` keeps the worst: the distance outside in metres and the
longest stretch outside in seconds (:class:`EnvelopeExcursion`; the definitions: docs/safety.md, "The envelope
excursion"). Pure: no I/O, no clock (the loop hands it the time and the positions).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol

from masonry.errors import InvalidArgument
from masonry.mission.volumes import Vec3, Volume
from masonry.reservation import Table
from masonry.separation import TRACK_SHARE_M

#: A UAV counts as out of its envelope, for the seconds, only this far from its volumes: its share of the tracking
#: error the separation pays for (the volumes are the nominal paths, a leg a line: a UAV hovering 4 mm over its
#: leg's altitude is where the separation expects it).
ALLOWANCE_M = TRACK_SHARE_M


@dataclass(frozen=True)
class EnvelopeExcursion:
    """The worst excursion of a mission's UAVs out of their reserved envelopes, as the world measured it.

    Attributes:
        m: the greatest distance, metres, from a UAV's true position to the volumes reserved for it at that
            instant (0.0: every UAV stayed inside; instants it held no volume at all count in ``s`` only).
        uav, at_s: whose and when (simulated seconds; "" and None: none was outside).
        s: the longest stretch, seconds, one UAV spent out of its envelope without a break: more than
            :data:`ALLOWANCE_M` from the volumes reserved for it, or holding none (0.0: none).
        s_uav, s_from_s: whose and when it began ("" and None: none).
    """

    m: float
    uav: str = ""
    at_s: float | None = None
    s: float = 0.0
    s_uav: str = ""
    s_from_s: float | None = None

    def to_dict(self) -> dict[str, float | str | None]:
        """The JSON report's ``envelope_excursion`` (to the millimetre and the hundredth of a second)."""
        return {
            "m": round(self.m, 3),
            "uav": self.uav,
            "at_s": _r2(self.at_s),
            "s": round(self.s, 2),
            "s_uav": self.s_uav,
            "s_from_s": _r2(self.s_from_s),
        }

    @classmethod
    def from_dict(cls, data: object) -> EnvelopeExcursion:
        """The value :meth:`to_dict` (or a record) wrote (raises InvalidArgument: not such a mapping)."""
        if not isinstance(data, dict):
            raise InvalidArgument(f"an envelope excursion must be an object, got {type(data).__name__}")
        try:
            at, since = data.get("at_s"), data.get("s_from_s")
            return cls(
                float(data["m"]),
                str(data.get("uav", "")),
                None if at is None else float(at),
                float(data["s"]),
                str(data.get("s_uav", "")),
                None if since is None else float(since),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidArgument(f"an envelope excursion is malformed: {exc}") from None

    def line(self) -> str:
        """A few words for the summary: how far and how long out of the envelope, who and when."""
        far = "" if self.at_s is None else f" ({self.uav} at {self.at_s:.1f} s)"
        long = "" if self.s_from_s is None else f" ({self.s_uav} from {self.s_from_s:.1f} s)"
        return f"envelope excursion {self.m:.2f} m{far}, {self.s:.2f} s out{long}"


def _r2(v: float | None) -> float | None:
    return None if v is None else round(v, 2)


def worse(a: EnvelopeExcursion | None, b: EnvelopeExcursion | None) -> EnvelopeExcursion | None:
    """The two together (a resumed mission: the run before the stop and this one): the worse of each figure."""
    if a is None or b is None:
        return a if b is None else b
    far = a if a.m >= b.m else b
    long = a if a.s >= b.s else b
    return EnvelopeExcursion(far.m, far.uav, far.at_s, long.s, long.s_uav, long.s_from_s)


class ReservedSpace(Protocol):
    """What the envelope is read from: mission control's airspace (both ``columns`` and ``table`` answer it)."""

    def reserved_at(self, uav: str, t_s: float) -> Sequence[Volume]:
        """The volumes reserved for ``uav`` at ``t_s`` (the columns: those it holds now)."""
        ...


class TableWindows:
    """A reservation table's volumes by UAV with their windows, read once per table (tables are values: a new
    one replaces the old at every change): what :meth:`TableClearance.reserved_at` answers from."""

    def __init__(self) -> None:
        self._table: Table | None = None
        self._by_uav: dict[str, list[tuple[float, float, Volume]]] = {}

    def at(self, table: Table, uav: str, t_s: float) -> tuple[Volume, ...]:
        """``uav``'s volumes in ``table`` whose window ``[t0_s, t1_s)`` holds ``t_s`` (a site's, where no UAV
        flies, left out)."""
        if table is not self._table:
            self._table, self._by_uav = table, {}
            for r in table.reservations:
                w = r.volume
                if w.kind != "site":
                    v = Volume(w.a, w.b, w.z0_m, w.z1_m, w.radius_m, r.purpose)
                    self._by_uav.setdefault(r.uav, []).append((r.t0_s, r.t1_s, v))
        return tuple(v for t0, t1, v in self._by_uav.get(uav, ()) if t0 <= t_s < t1)


def outside_m(p: Vec3, volumes: Iterable[Volume]) -> float:
    """Distance (3-D) from ``p`` to the union of ``volumes`` (0.0 inside one; ``math.inf`` for none).

    A volume is every point within ``slack_m`` (horizontally) of its segment, between ``z0_m`` and ``z1_m``: the
    distance is the hypotenuse of how far ``p`` lies out of it sideways and how far above or below it.
    """
    px, py, pz = p
    best = math.inf
    for v in volumes:
        (ax, ay), (bx, by) = v.a, v.b
        dx, dy = bx - ax, by - ay
        ex, ey = px - ax, py - ay
        n2 = dx * dx + dy * dy
        if n2 > 0.0:
            t = (ex * dx + ey * dy) / n2
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
            ex, ey = ex - t * dx, ey - t * dy
        h = math.sqrt(ex * ex + ey * ey) - v.slack_m
        z = v.z0_m - pz if pz < v.z0_m else (pz - v.z1_m if pz > v.z1_m else 0.0)
        if h <= 0.0:
            d = z
        elif z == 0.0:
            d = h
        else:
            d = math.hypot(h, z)
        if d <= 0.0:
            return 0.0  # (inside one: the rest need not be looked at)
        if d < best:  # noqa: PLR1730 (no min() call: the loop runs for every UAV at every step)
            best = d
    return best


class EnvelopeWatch:
    """The worst envelope excursion so far of the UAVs it is shown (:meth:`observe`, after each world step).

    Args:
        airspace: mission control's airspace (:class:`ReservedSpace`).
        every_s: look at most this often, simulated seconds (0.0: at every step it is shown); a stretch out of the
            envelope is then known to within this interval.
    """

    def __init__(self, airspace: ReservedSpace, every_s: float = 0.0) -> None:
        if not (every_s >= 0.0 and math.isfinite(every_s)):
            raise InvalidArgument(f"every_s must be a finite number >= 0, got {every_s!r}")
        self.airspace = airspace
        self.every_s = float(every_s)
        self.looks = 0  # UAV positions looked at (the benchmark's count)
        self._far = EnvelopeExcursion(0.0)  # the worst distance so far (its m, uav, at_s)
        self._long: tuple[float, str, float | None] = (0.0, "", None)  # the longest stretch ended so far
        self._next_s = -math.inf
        self._out_since: dict[str, float] = {}  # UAV -> when its stretch out began (the first look out)

    def observe(self, now_s: float, airborne: Sequence[tuple[str, Vec3]]) -> None:
        """The UAVs flying at ``now_s`` and where they truly are; every other UAV is on the ground (or fallen)."""
        if now_s < self._next_s:
            return
        self._next_s = now_s + self.every_s - 1e-9
        reserved_at = self.airspace.reserved_at
        out = self._out_since
        far_m = self._far.m
        for uav, p in airborne:
            d = outside_m(p, reserved_at(uav, now_s))
            if far_m < d < math.inf:
                self._far, far_m = EnvelopeExcursion(d, uav, now_s), d
            if d > ALLOWANCE_M:
                out.setdefault(uav, now_s)
            elif out and uav in out:
                self._back(uav, now_s)
        self.looks += len(airborne)
        if out:
            flying = {uav for uav, _p in airborne}
            for uav in [u for u in out if u not in flying]:
                self._back(uav, now_s)  # (landed, or fell: its stretch out ends)

    def _back(self, uav: str, now_s: float) -> None:
        since = self._out_since.pop(uav)
        if now_s - since > self._long[0]:
            self._long = (now_s - since, uav, since)

    def worst(self, now_s: float | None = None) -> EnvelopeExcursion:
        """The worst so far; a stretch still going on counts up to ``now_s`` (None: not at all)."""
        s, s_uav, since = self._long
        for uav, t0 in self._out_since.items():
            if now_s is not None and now_s - t0 > s:
                s, s_uav, since = now_s - t0, uav, t0
        far = self._far
        return EnvelopeExcursion(far.m, far.uav, far.at_s, s, s_uav, since)


__all__ = [
    "ALLOWANCE_M",
    "EnvelopeExcursion",
    "EnvelopeWatch",
    "ReservedSpace",
    "TableWindows",
    "outside_m",
    "worse",
]
