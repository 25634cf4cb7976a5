"""Wind as flight simulators model it: a mean wind with a power-law profile plus Dryden turbulence.

- **Mean wind**: ``speed_mps`` blowing *from* ``direction_deg`` (meteorological: clockwise from north, the
  world's +y; ArduPilot's WIND message and ``SIM_WIND_DIR`` use the same convention), given at
  ``reference_height_m`` (10 m, where forecasts and anemometers give it) and scaled with height by the power law
  ``U(z) = U_ref (z / z_ref) ** shear_exponent`` (1/7: open terrain), below ``min_profile_height_m`` held at its
  value there. ``schedule`` (``(time_s, speed_mps)`` points, linear between, held after the last) makes the speed
  change over the mission: a front coming through and going again.
- **Turbulence**: the Dryden model of MIL-F-8785C / MIL-HDBK-1797 at low altitude (below 1000 ft), in the wind's
  axes (u along the mean wind, v across it, w vertical). Intensities ``sigma_w = 0.1 W20``,
  ``sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h) ** 0.4`` and scale lengths ``L_w = h``,
  ``L_u = L_v = h / (0.177 + 0.000823 h) ** 1.2`` (h in feet, at least 10 ft as the standard's low-altitude model
  is written for); ``W20`` (wind at 20 ft) is 15, 30, 45 knots for ``light``, ``moderate``, ``severe``. A number
  instead of a level is ``sigma_u`` in m/s (the vertical intensity keeps the standard's ratio). The spatial
  spectra become temporal through Taylor's frozen turbulence convected past the vehicle at the mean wind speed
  (at least ``min_convection_mps``: a hovering UAV in calm air still meets eddies): ``u`` is a first-order
  (Ornstein-Uhlenbeck) process of time constant ``L_u / V``, ``v`` and ``w`` the standard's second-order forms
  ``(1 + sqrt(3) T s) / (1 + T s) ** 2`` with ``T = 2 L / V``, discretised exactly.

:class:`WindField` is one UAV's wind (its own seeded stream): ``at(t_s, z_m)`` is deterministic in simulated time,
whatever steps the caller takes: the turbulence moves on a fixed ``grid_s`` grid, linearly interpolated between.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from masonry.errors import InputError

__all__ = [
    "TURBULENCE_LEVELS",
    "WindConfig",
    "WindField",
    "dryden_low_altitude",
]

_FT = 0.3048
_KNOT = 0.514444
#: MIL-F-8785C's W20 (wind speed at 20 ft) for each turbulence level, m/s.
TURBULENCE_LEVELS: dict[str, float] = {"light": 15 * _KNOT, "moderate": 30 * _KNOT, "severe": 45 * _KNOT}
#: Beyond this mean wind (m/s at 10 m, a severe gale) no small UAV flies: a larger value is a typing mistake.
MAX_WIND_MPS = 30.0
MAX_TURBULENCE_MPS = 15.0


@dataclass(frozen=True)
class WindConfig:
    """A site's wind: mean wind, its profile and schedule, and turbulence (SI units; see the module docstring).

    Attributes:
        speed_mps: mean wind speed at ``reference_height_m``.
        direction_deg: where the wind blows from, clockwise from north (+y).
        turbulence: ``none``, ``light``, ``moderate``, ``severe`` or ``custom`` (then ``turbulence_mps``).
        turbulence_mps: with ``custom``: the horizontal intensity sigma_u, m/s.
        schedule: ``(time_s, speed_mps)`` points of the mean speed over time (empty: ``speed_mps`` throughout).
    """

    speed_mps: float = 0.0
    direction_deg: float = 0.0
    turbulence: str = "none"
    turbulence_mps: float = 0.0
    schedule: tuple[tuple[float, float], ...] = ()
    reference_height_m: float = 10.0
    shear_exponent: float = 1.0 / 7.0
    min_profile_height_m: float = 0.5
    min_convection_mps: float = 1.0
    grid_s: float = 0.05

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed_mps) and 0.0 <= self.speed_mps <= MAX_WIND_MPS):
            raise InputError(f"wind speed must be from 0 to {MAX_WIND_MPS:g} m/s, got {self.speed_mps!r}")
        if not math.isfinite(self.direction_deg):
            raise InputError(f"wind direction must be a finite angle in degrees, got {self.direction_deg!r}")
        if self.turbulence not in (*TURBULENCE_LEVELS, "none", "custom"):
            raise InputError(
                f"turbulence must be none, light, moderate, severe or custom, got {self.turbulence!r}"
            )
        if not (math.isfinite(self.turbulence_mps) and 0.0 <= self.turbulence_mps <= MAX_TURBULENCE_MPS):
            raise InputError(
                f"turbulence intensity must be from 0 to {MAX_TURBULENCE_MPS:g} m/s, got {self.turbulence_mps!r}"
            )
        last = -math.inf
        for point in self.schedule:
            t_s, v = point
            if not (math.isfinite(t_s) and t_s >= 0.0 and t_s > last):
                raise InputError(f"wind schedule: times must be finite, >= 0 and increasing, got {point!r}")
            if not (math.isfinite(v) and 0.0 <= v <= MAX_WIND_MPS):
                raise InputError(
                    f"wind schedule: speeds must be from 0 to {MAX_WIND_MPS:g} m/s, got {point!r}"
                )
            last = t_s
        for name in ("reference_height_m", "min_profile_height_m", "min_convection_mps", "grid_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f"WindConfig.{name} must be finite and > 0, got {value!r}")
        if not (math.isfinite(self.shear_exponent) and 0.0 <= self.shear_exponent < 1.0):
            raise InputError(f"WindConfig.shear_exponent must be in [0, 1), got {self.shear_exponent!r}")

    @property
    def turbulent(self) -> bool:
        """Turbulence is on (a level, or a custom intensity above 0)."""
        return self.turbulence in TURBULENCE_LEVELS or (
            self.turbulence == "custom" and self.turbulence_mps > 0
        )

    @property
    def calm(self) -> bool:
        """No mean wind at any time and no turbulence: still air."""
        return self.speed_mps == 0.0 and all(v == 0.0 for _, v in self.schedule) and not self.turbulent

    def speed_at(self, t_s: float) -> float:
        """The mean wind speed at the reference height at simulated time ``t_s``."""
        points = self.schedule
        if not points:
            return self.speed_mps
        if t_s <= points[0][0]:
            return points[0][1]
        for (t0, v0), (t1, v1) in itertools.pairwise(points):
            if t_s <= t1:
                return v0 + (v1 - v0) * (t_s - t0) / (t1 - t0)
        return points[-1][1]

    def profile(self, z_m: float) -> float:
        """The power-law factor U(z) / U_ref at height ``z_m`` above the ground."""
        z = max(z_m, self.min_profile_height_m)
        return float((z / self.reference_height_m) ** self.shear_exponent)

    def mean_mps(self, t_s: float, z_m: float) -> tuple[float, float]:
        """The mean wind vector (ENU x, y; where the air goes) at time ``t_s`` and height ``z_m``."""
        speed = self.speed_at(t_s) * self.profile(z_m)
        d = math.radians(self.direction_deg)
        return (-speed * math.sin(d), -speed * math.cos(d))

    def describe(self) -> str:
        """One line for reports: ``4 m/s from 270 deg, light turbulence``."""
        mean = (
            f"{self.speed_mps:g} m/s from {self.direction_deg % 360:g} deg"
            if not self.schedule
            else "scheduled"
        )
        if self.turbulence == "none":
            return f"{mean}, no turbulence"
        if self.turbulence == "custom":
            return f"{mean}, turbulence sigma {self.turbulence_mps:g} m/s"
        return f"{mean}, {self.turbulence} turbulence"


def dryden_low_altitude(config: WindConfig, z_m: float) -> tuple[float, float, float, float, float]:
    """MIL-F-8785C low-altitude Dryden parameters at height ``z_m``: (sigma_u, sigma_w, L_u, L_w), m/s and m,
    and the vertical-to-horizontal intensity ratio."""
    h_ft = min(max(z_m / _FT, 10.0), 1000.0)
    k = 0.177 + 0.000823 * h_ft
    ratio = k**0.4  # sigma_w / sigma_u
    l_u = h_ft / k**1.2 * _FT
    l_w = h_ft * _FT
    if config.turbulence in TURBULENCE_LEVELS:
        sigma_w = 0.1 * TURBULENCE_LEVELS[config.turbulence]
        sigma_u = sigma_w / ratio
    elif config.turbulence == "custom":
        sigma_u = config.turbulence_mps
        sigma_w = sigma_u * ratio
    else:
        sigma_u = sigma_w = 0.0
    return sigma_u, sigma_w, l_u, l_w, ratio


class _SecondOrder:
    """Unit-variance samples of the Dryden v/w shape ``(1 + sqrt(3) T s) / (1 + T s) ** 2`` on a fixed step.

    Two cascaded first-order states driven by white noise (x1 = p/(s+p) n, x2 = p/(s+p) x1, p = 1/T): the output
    ``sqrt(3) x1 + (1 - sqrt(3)) x2`` has the shape; its stationary variance is p, divided out. The step is exact
    (transition matrix and noise covariance in closed form).
    """

    __slots__ = ("_c", "_key", "_l11", "_l21", "_l22", "_p", "_phi", "x1", "x2")

    def __init__(self) -> None:
        self.x1 = self.x2 = 0.0
        self._key = (-1.0, -1.0)
        self._p = 1.0
        self._phi = self._c = self._l11 = self._l21 = self._l22 = 0.0

    def start(self, p: float, z1: float, z2: float) -> None:
        """Draw the stationary state (P11 = p/2, P12 = P22 = p/4)."""
        a = math.sqrt(p / 2.0)
        b = (p / 4.0) / a
        c = math.sqrt(max(p / 4.0 - b * b, 0.0))
        self.x1, self.x2 = a * z1, b * z1 + c * z2
        self._p = p

    def _discretise(self, p: float, dt: float) -> None:
        e = math.exp(-p * dt)
        a = 2.0 * p
        ea = math.exp(-a * dt)
        i0 = (1.0 - ea) / a
        i1 = (1.0 - ea * (1.0 + a * dt)) / (a * a)
        i2 = (2.0 - ea * (a * a * dt * dt + 2.0 * a * dt + 2.0)) / (a * a * a)
        q11, q12, q22 = p * p * i0, p**3 * i1, p**4 * i2
        self._l11 = math.sqrt(q11)
        self._l21 = q12 / self._l11
        self._l22 = math.sqrt(max(q22 - self._l21 * self._l21, 0.0))
        self._phi, self._c = e, p * dt * e
        self._p = p
        self._key = (p, dt)

    def step(self, p: float, dt: float, z1: float, z2: float) -> float:
        if (p, dt) != self._key:
            self._discretise(p, dt)
        e, c = self._phi, self._c
        x1, x2 = self.x1, self.x2
        self.x1 = e * x1 + self._l11 * z1
        self.x2 = c * x1 + e * x2 + self._l21 * z1 + self._l22 * z2
        return (math.sqrt(3.0) * self.x1 + (1.0 - math.sqrt(3.0)) * self.x2) / math.sqrt(p)

    def value(self) -> float:
        return (math.sqrt(3.0) * self.x1 + (1.0 - math.sqrt(3.0)) * self.x2) / math.sqrt(self._p)


class WindField:
    """One UAV's wind: ``at(t_s, z_m)`` -> the air's velocity (ENU, m/s) there and then.

    Args:
        config: the site's wind.
        rng: the turbulence's own stream (seeded by the caller: the same seed gives the same wind).
        start_s: the simulated time the field starts at.
    """

    def __init__(self, config: WindConfig, rng: np.random.Generator, start_s: float = 0.0) -> None:
        self.config = config
        self._rng = rng
        self._buf: list[float] = []
        self._i = 0
        self._t0 = float(start_s)
        self._k = 0  # grid index of the newest sample
        self._u = self._gauss()
        self._v, self._w = _SecondOrder(), _SecondOrder()
        self._prev = self._cur = (0.0, 0.0, 0.0)  # unit-variance (u, v, w) at grid k-1, k
        self._z = 0.0
        self._started = False
        self.turbulent = config.turbulent

    def _gauss(self) -> float:
        if self._i >= len(self._buf):
            self._buf = self._rng.standard_normal(1024).tolist()
            self._i = 0
        value = self._buf[self._i]
        self._i += 1
        return value

    def _rates(self, t_s: float, z_m: float) -> tuple[float, float, float]:
        """1 / time constant of u, and p = V / (2 L) of v and w, at this time and height."""
        cfg = self.config
        _, _, l_u, l_w, _ = dryden_low_altitude(cfg, z_m)
        v = max(cfg.speed_at(t_s) * cfg.profile(z_m), cfg.min_convection_mps)
        return v / l_u, v / (2.0 * l_u), v / (2.0 * l_w)

    def _advance_to(self, k: int) -> None:
        """Move the unit-variance turbulence on to grid index ``k``."""
        dt = self.config.grid_s
        if not self._started:
            self._started = True
            _, pv, pw = self._rates(self._t0, self._z)
            self._v.start(pv, self._gauss(), self._gauss())
            self._w.start(pw, self._gauss(), self._gauss())
            self._cur = self._prev = (self._u, self._v.value(), self._w.value())
        while self._k < k:
            self._k += 1
            ru, pv, pw = self._rates(self._t0 + self._k * dt, self._z)
            phi = math.exp(-ru * dt)
            self._u = phi * self._u + math.sqrt(1.0 - phi * phi) * self._gauss()
            v = self._v.step(pv, dt, self._gauss(), self._gauss())
            w = self._w.step(pw, dt, self._gauss(), self._gauss())
            self._prev, self._cur = self._cur, (self._u, v, w)

    def turbulence_mps(self, t_s: float, z_m: float) -> tuple[float, float, float]:
        """The turbulence alone in the wind's axes (u along the mean wind, v across it, w up), m/s."""
        if not self.turbulent:
            return (0.0, 0.0, 0.0)
        self._z = z_m
        pos = (t_s - self._t0) / self.config.grid_s
        k = max(math.ceil(pos - 1e-9), 0)  # 1.0 / 0.05 is 20.000000000000004: grid point 20, not 21
        if k > self._k or not self._started:
            self._advance_to(k)
        f = 1.0 - (self._k - pos) if self._k > 0 else 1.0
        f = min(max(f, 0.0), 1.0)
        a, b = self._prev, self._cur
        sigma_u, sigma_w, _, _, _ = dryden_low_altitude(self.config, z_m)
        return (
            sigma_u * (a[0] + (b[0] - a[0]) * f),
            sigma_u * (a[1] + (b[1] - a[1]) * f),
            sigma_w * (a[2] + (b[2] - a[2]) * f),
        )

    def at(self, t_s: float, z_m: float) -> tuple[float, float, float]:
        """The air's velocity (ENU x, y, z; m/s) at simulated time ``t_s`` and height ``z_m`` above the ground."""
        cfg = self.config
        mx, my = cfg.mean_mps(t_s, z_m)
        if not self.turbulent:
            return (mx, my, 0.0)
        u, v, w = self.turbulence_mps(t_s, z_m)
        # the wind's axes: u along where the mean wind goes (the direction it blows toward), v to its left
        d = math.radians(cfg.direction_deg)
        ex, ey = -math.sin(d), -math.cos(d)
        return (mx + u * ex - v * ey, my + u * ey + v * ex, w)
