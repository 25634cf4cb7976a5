"""The UAV model's motion: the navigator's legs and routes, and the airspace transit's asking (docs/safety.md).

Every state moves the UAV through these methods: a hover, one minimum-jerk leg, a line, or a *route* that climbs
first and descends last; with a :class:`~masonry.ports.ClearanceLink` a route is a transit, which asks mission
control for the column over its site once at rest, waits at a hold point when told to, flies the layer it is
given and comes down (:class:`~masonry.fsm.transit.Transit` keeps its phase and what its requests carry). The
navigator is changed only through its methods.
"""

from __future__ import annotations

import math

import numpy as np

from masonry.fsm.base import ModelBase, Vec3
from masonry.fsm.transit import flight_of, progress_on
from masonry.ports import ClearanceAnswer, PlanProgress, Telemetry
from masonry.segments import point_segment_m
from masonry.separation import LEG_OVERSHOOT_M, TRACK_SHARE_M

#: A UAV flies on over its hold point to its site (:meth:`Routing._straight_on`) only from farther than this: one
#: nearer is as good as there (within a leg's arrival tolerances), and flying on from there changed the order of
#: the multi-UAV runs, not their time (the 12 m wall at 4 + 2: 1,189 -> 1,236 s).
STRAIGHT_ON_FROM_M = 0.25


class Routing(ModelBase):
    """Motion for the model's states: hover, legs, lines, routes and the transit (see the module's docstring)."""

    def site_text(self) -> str:
        """Where the transit goes (the column asked for), as the reasons write it."""
        x, y, z = self.transit.site_m
        return f"({x:.2f}, {y:.2f}, {z:.2f})"

    def _stop(self) -> None:
        self.transit.drop()
        self.nav.stop()

    def _hold(self, tel: Telemetry, target_m: np.ndarray | None = None, yaw_rad: float | None = None) -> None:
        """Hover at ``target_m`` (default: where the UAV is) with the given yaw (default: keep it)."""
        self.nav.hold(self._now_s, tel, target_m, yaw_rad)

    def _fly_to(
        self,
        tel: Telemetry,
        target_m: np.ndarray,
        duration_s: float | None = None,
        yaw_rad: float | None = None,
        from_rest: bool = False,
        lag_s: float | None = None,
    ) -> None:
        """One minimum-jerk leg to rest at ``target_m`` (:meth:`Navigator.fly_to`)."""
        self.nav.fly_to(self._now_s, tel, target_m, duration_s, yaw_rad, from_rest, lag_s)

    def _fly_line(self, tel: Telemetry, start_m: np.ndarray, end_m: np.ndarray, speed_mps: float) -> None:
        """Track ``start -> end`` at constant ``speed_mps`` (reference starts at ``start`` now)."""
        self.nav.fly_line(self._now_s, start_m, end_m, speed_mps)

    def _yaw_error(self, tel: Telemetry) -> float:
        return self.nav.yaw_error_rad(tel)

    def _route(
        self,
        tel: Telemetry,
        target_m: np.ndarray,
        yaw_rad: float | None = None,
        top_m: float | None = None,
        to_m: np.ndarray | None = None,
    ) -> None:
        """Go to ``target_m`` climbing first if it is higher, descending last if it is lower (never diagonal).

        With a clearance link (mission control's airspace, docs/safety.md) a lateral move is a *transit*: the
        UAV first asks for the column over the target, hovering where it is; then climbs (or descends) to the
        layer it is given, flies there, and descends over the target once the column is its (until then it
        waits at its layer at the hold point it is given). Without one, with a fixed
        ``config.lateral_altitude_m``, the lateral leg flies at that altitude. ``top_m``: the highest altitude
        the UAV will reach while working at the target (default: the target's), ``to_m`` where that work ends if
        it moves along a segment (an adhesion UAV spraying): mission control reserves both.
        """
        self.transit.drop()
        if self.clearance is None:
            self.nav.route(self._now_s, tel, target_m, yaw_rad)
            return
        # even a move of a few centimetres (the next adhesion segment starts where the last one ended): the
        # work there is another span of airspace, which mission control must reserve
        target = np.asarray(target_m, dtype=float)
        self.nav.legs_moving()
        self.transit.begin(
            (float(target[0]), float(target[1]), float(target[2])),
            top_m,
            None if to_m is None else (float(to_m[0]), float(to_m[1]), float(to_m[2])),
        )
        # hover until mission control answers, once come to rest smoothly: it asks once settled, and the flight
        # it is granted starts from rest where it says it is
        stop = self.nav.stop_point_m(tel)
        if self.nav.rests_at(tel, stop):
            self._fly_to(tel, stop, 0.1, yaw_rad=yaw_rad, from_rest=True)  # at rest there already
        else:
            self._fly_to(tel, stop, yaw_rad=yaw_rad)

    def _advance(self, tel: Telemetry, tolerance_m: float | None = None) -> bool:
        """Move the route on at the end of a leg (its next leg, the transit's next phase); True once the whole
        motion is over and the UAV within ``tolerance_m`` of its end."""
        if self.transit.state == "hold" and not self.nav.legs and self._straight_on(tel):
            return False
        if not self.nav.at_end(self._now_s, tel, tolerance_m):
            return False
        if self.nav.legs:
            self.nav.next_leg(self._now_s, tel)
            return False
        if self.transit.active:
            return self._transit_step(tel)
        return True

    def _transit_step(self, tel: Telemetry) -> bool:
        """A transit's motion is over (see :meth:`_route`): ask, go on, or finish; True when it has arrived."""
        assert self.clearance is not None
        transit = self.transit
        if transit.state == "down":
            transit.arrive()
            transit.flight = None
            self.clearance.end_transit(transit.site_m)
            return True
        self.nav.begin_settling(self._now_s)
        if not self.nav.settled(self._now_s, tel):
            self.nav.wait(self._now_s)  # let it settle first (a leg timeout does not run meanwhile)
            return False
        answer = self.clearance.request_clearance(transit.site_m, transit.top_m, transit.to_m)
        if answer is None:
            self.nav.wait(self._now_s)  # no answer yet: hover (a leg timeout does not run meanwhile)
            return False
        p = np.asarray(tel.position_m, dtype=float)
        layer = self._transit_layer_m(answer, p)
        if answer.granted:
            self._site_granted(answer)
            self._granted(tel, p, answer.layer_m if answer.layer_m is not None else layer, answer.gentle)
            self._note_flight(answer.grant, p)
        else:
            # a hold flight at the altitude it is given: a later one may be at another (to a parking spot)
            hold_layer = answer.layer_m if answer.hold_m is not None and answer.layer_m is not None else layer
            if self._refused(tel, p, answer.hold_m, hold_layer, answer.gentle):
                self._note_flight(answer.grant, p)
        return False

    def _note_flight(self, grant: int, p: np.ndarray) -> None:
        """The navigator now flies the flight of mission control's answer numbered ``grant`` from ``p`` (granted,
        or a hold flight): its legs are kept, for :meth:`plan_progress` (an answer not numbered: none)."""
        if grant <= 0:
            self.transit.flight = None
            return
        nav = self.nav
        points = [(float(p[0]), float(p[1]), float(p[2]))]
        for q in (nav.target_m, *(end for end, _d in nav.legs)):
            points.append((float(q[0]), float(q[1]), float(q[2])))
        self.transit.flight = flight_of(grant, points)

    def plan_progress(self, position_m: Vec3 | None) -> PlanProgress | None:
        """How far the UAV at ``position_m`` is along the flight mission control last answered it (its
        ``plan_progress`` fact, :class:`~masonry.ports.PlanProgress`); None: it flies none (none asked for, none
        numbered, arrived, or it stopped or turned back)."""
        flight = self.transit.flight
        if flight is None or position_m is None or not self.transit.active:
            return None
        t = self.nav.target_m
        return progress_on(flight, (float(t[0]), float(t[1]), float(t[2])), len(self.nav.legs), position_m)

    def _straight_on(self, tel: Telemetry) -> bool:
        """On the lateral leg to a hold point that lies on the straight line to the site: if the rest of the flight
        is granted at this layer meanwhile, fly on over the hold point to the site without stopping there (mission
        control reserved the line: docs/safety.md, "Straight on over the hold point"); True if it does."""
        assert self.clearance is not None
        transit, target = self.transit, self.nav.target_m
        layer, site = transit.layer_m, transit.site_m
        pos = tel.position_m  # (floats: asked on every tick of a hold flight's lateral leg)
        if layer is None or abs(float(target[2]) - layer) > 1e-6 or abs(float(pos[2]) - layer) > 0.2:
            return False
        px, py = float(pos[0]), float(pos[1])
        if point_segment_m((float(target[0]), float(target[1])), (px, py), (site[0], site[1])) > 0.02:
            return False
        if math.hypot(float(target[0]) - px, float(target[1]) - py) < STRAIGHT_ON_FROM_M:
            return False  # (as good as there: it stops and reads the answer at rest, as before)
        p = np.asarray(pos, dtype=float)
        answer = self.clearance.request_clearance(site, transit.top_m, transit.to_m)
        if (
            answer is None
            or not answer.granted
            or answer.layer_m is None
            or abs(answer.layer_m - layer) > 1e-6
        ):
            return False
        self._site_granted(answer)
        transit.grant()
        legs = self.nav.layer_route_legs(np.array(site), layer)
        # on at the layer with the lateral speed it has, not the vertical one (:meth:`Navigator.fly_to`'s level)
        accel = self._end_accel_mps2(answer.gentle)
        duration_s = None if accel is None else self.nav.leg_duration_s(p, legs[0][0], accel)
        self.nav.fly_to(self._now_s, tel, legs[0][0], duration_s, yaw_rad=self.nav.target_yaw_rad, level=True)
        self.nav.legs = legs[1:]
        self.nav.legs_from_rest = True
        self._note_flight(answer.grant, p)
        return True

    def _transit_layer_m(self, answer: ClearanceAnswer, p: np.ndarray) -> float:
        """The altitude of the transit's lateral legs: the one it has, else the answer's, else where it is. An
        answer with no layer (no layers; mission control silent past ``LAST_RESORT_S``: nobody to ask) flies the
        UAV's fixed ``config.lateral_altitude_m``, the fallback layer mission control reserves its way home at,
        even when an earlier answer of the same transit gave it another (docs/safety.md, "Guarantees and what is
        not covered")."""
        if answer.layer_m is None and self.config.lateral_altitude_m is not None:
            return self.config.lateral_altitude_m
        layer = self.transit.layer_m
        if layer is None:
            layer = answer.layer_m
            if layer is None:  # no layers: the altitude it is at (or the target's, if higher)
                layer = max(float(p[2]), float(self.transit.site_m[2]))
        return layer

    def _site_granted(self, answer: ClearanceAnswer) -> None:
        """Mission control granted the transit's site with ``answer`` (the brick UAV reads its glue's open time)."""

    def _granted(self, tel: Telemetry, p: np.ndarray, layer: float, gentle: bool = True) -> None:
        """The column is the UAV's: fly there at ``layer`` (from a hold point perhaps another layer) and down
        (``gentle``: mission control's :attr:`~masonry.ports.ClearanceAnswer.gentle`)."""
        self.transit.layer_m = layer
        self.transit.grant()
        target = np.array(self.transit.site_m)
        if math.hypot(target[0] - p[0], target[1] - p[1]) <= 0.05:
            # already over the site: no lateral leg, no layer
            self.nav.low_route(self._now_s, tel, p, target, self.nav.target_yaw_rad, from_rest=True)
        else:
            home = self.config.home_m
            # into the column over its own pad (no slack there beyond the tracking error's): gently
            to_pad = math.hypot(target[0] - home[0], target[1] - home[1]) <= 0.05
            accel = self.config.pad_leg_accel_mps2 if to_pad else self._end_accel_mps2(gentle)
            self.nav.layer_route(self._now_s, tel, p, target, layer, self.nav.target_yaw_rad, accel)

    def _end_accel_mps2(self, gentle: bool = True) -> float | None:
        """The acceleration a lateral leg into a work zone or to a hold hover is flown within:
        ``zone_leg_accel_mps2`` if their slack does not cover a short leg's overshoot and mission control has not
        widened its end for it (``gentle``: something of another UAV's is near there); else (None) the legs' own."""
        cfg = self.config
        if cfg.zone_slack_m + TRACK_SHARE_M >= LEG_OVERSHOOT_M or not math.isfinite(cfg.zone_leg_accel_mps2):
            return None
        if not gentle:
            return None  # (its end has room for the overshoot: masonry.mission.airspace_requests.fast_end)
        return cfg.zone_leg_accel_mps2

    def _refused(
        self, tel: Telemetry, p: np.ndarray, hold: Vec3 | None, layer: float, gentle: bool = True
    ) -> bool:
        """Not yet: wait at the hold point given (flying there at ``layer``, gently if ``gentle``: True), or where
        the UAV is (False). A hold point at its layer straight under or over the UAV is flown to as well: a UAV
        turned back over the stay its plan ends in flies on down into it (docs/safety.md, "A UAV turned back")."""
        first = self.transit.state == "ask"
        if hold is not None and (
            first
            or math.hypot(hold[0] - p[0], hold[1] - p[1]) > 0.05
            or (abs(hold[2] - layer) < 1e-6 and abs(layer - float(p[2])) > 0.05)
        ):
            self.transit.layer_m = layer
            self.transit.wait()
            self.nav.layer_route(
                self._now_s,
                tel,
                p,
                np.array([hold[0], hold[1], layer]),
                layer,
                self.nav.target_yaw_rad,
                self._end_accel_mps2(gentle),
            )
            return True
        self.nav.wait(self._now_s)
        return False
