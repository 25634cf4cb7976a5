"""Minimum-jerk trajectories between full kinematic states (paper Sec. IV, trajectory equation, after Kumar & Padhi).

The trajectory minimises ``1/2 * integral |jerk|^2 dt`` with position, velocity and acceleration fixed at both ends;
the minimiser is a quintic in time. We write it in ``t`` (time since the start)::

    r(t) = r0 + v0 t + a0 t^2 / 2 + k3 t^3 + k4 t^4 + k5 t^5

with ``T = duration_s``, ``dr = rf - (r0 + v0 T + a0 T^2/2)``, ``dv = vf - (v0 + a0 T)``, ``da = af - a0``::

    k3 = (10 dr - 4 dv T +   da T^2 / 2) / T^3
    k4 = (-15 dr + 7 dv T -  da T^2)     / T^4
    k5 = (6 dr - 3 dv T +    da T^2 / 2) / T^5

This is the paper's quintic in ``t_go`` rewritten in ``t``; the paper's ``c2`` has its ``Z_a0`` term with the wrong
sign (``+Z_a0/t_go^2`` instead of ``-Z_a0/t_go^2``), which moves ``r(0)`` by ``2 (a0 - af) T^2``; see
docs/estimation.md for the derivation and ``paper_coefficients`` for both forms.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from masonry.errors import PlanningError

ArrayLike3 = Sequence[float] | np.ndarray
Vec3f = tuple[float, float, float]

MIN_T_GO_S = 0.1
"""Floor on the remaining time used by :meth:`MinJerk.replan`: the coefficients grow like ``1/t_go^5``."""


def _floats3(name: str, value: ArrayLike3) -> tuple[float, float, float]:
    items = value.tolist() if isinstance(value, np.ndarray) else value
    try:
        x, y, z = items
        x, y, z = float(x), float(y), float(z)
    except (TypeError, ValueError):
        raise PlanningError(f"min-jerk {name} must have 3 components, got shape {np.shape(value)}") from None
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise PlanningError(f"min-jerk {name} must be finite, got {[x, y, z]}")
    return x, y, z


def _frozen(values: Sequence[float] | Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    arr = np.array(values, dtype=float)
    arr.flags.writeable = False
    return arr


# _HORNER[order]: (i, i!/(i - order)!) from i = 5 down to order: the factor of c_i in the order-th derivative.
_HORNER = tuple(
    tuple((i, math.factorial(i) / math.factorial(i - order)) for i in range(5, order - 1, -1))
    for order in range(4)
)


class MinJerk:
    """Minimum-jerk quintic from ``(r0, v0, a0)`` to ``(rf, vf, af)`` in ``duration_s`` (3-D, SI units).

    Evaluation methods take ``t`` in seconds since the start: a scalar gives shape ``(3,)``, an array of shape
    ``S`` gives ``S + (3,)``. Outside ``[0, duration_s]`` the trajectory continues the boundary state at constant
    acceleration (zero jerk), so position, velocity and acceleration stay consistent and bounded in time.
    Immutable; the boundary states are exposed as read-only arrays ``r0 v0 a0 rf vf af``.

    Raises:
        PlanningError: a state is not a finite 3-vector or ``duration_s`` is not a positive finite number.
    """

    __slots__ = ("_arrays", "_rows", "_states", "duration_s")

    duration_s: float
    _states: tuple[tuple[float, float, float], ...]
    _rows: tuple[tuple[tuple[float, float, float], ...], ...]
    _arrays: dict[str, np.ndarray]

    def __init__(
        self,
        r0: ArrayLike3,
        v0: ArrayLike3,
        a0: ArrayLike3,
        rf: ArrayLike3,
        vf: ArrayLike3,
        af: ArrayLike3,
        duration_s: float,
    ) -> None:
        # Plain floats throughout: a trajectory is re-planned at every control tick, so construction must be cheap.
        states = (
            _floats3("r0", r0),
            _floats3("v0", v0),
            _floats3("a0", a0),
            _floats3("rf", rf),
            _floats3("vf", vf),
            _floats3("af", af),
        )
        T = float(duration_s)
        if not (math.isfinite(T) and T > 0.0):
            raise PlanningError(f"min-jerk duration_s must be positive and finite, got {duration_s!r}")
        T2, T3, T4, T5 = T * T, T**3, T**4, T**5
        cols = []
        for r0_, v0_, a0_, rf_, vf_, af_ in zip(*states):
            dr = rf_ - (r0_ + v0_ * T + a0_ * T2 / 2.0)
            dv = vf_ - (v0_ + a0_ * T)
            da = af_ - a0_
            k3 = (10.0 * dr - 4.0 * dv * T + da * T2 / 2.0) / T3
            k4 = (-15.0 * dr + 7.0 * dv * T - da * T2) / T4
            k5 = (6.0 * dr - 3.0 * dv * T + da * T2 / 2.0) / T5
            cols.append((r0_, v0_, a0_ / 2.0, k3, k4, k5))
        c = list(zip(*cols))  # c[i] = (x, y, z) coefficient of t^i in the position
        # rows[order]: coefficients (x, y, z) of the order-th derivative, highest power first (Horner order).
        rows = tuple(
            tuple((f * c[i][0], f * c[i][1], f * c[i][2]) for i, f in _HORNER[order]) for order in range(4)
        )
        object.__setattr__(self, "duration_s", T)
        object.__setattr__(self, "_states", states)
        object.__setattr__(self, "_rows", rows)
        object.__setattr__(self, "_arrays", {})

    def __setattr__(self, name: str, value: object) -> None:
        raise AttributeError(f"MinJerk is immutable: cannot set {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"MinJerk is immutable: cannot delete {name!r}")

    def _array(self, key: str, build: Callable[[], np.ndarray]) -> np.ndarray:
        arr = self._arrays.get(key)
        if arr is None:
            arr = _frozen(build())
            self._arrays[key] = arr
        return arr

    @property
    def r0(self) -> np.ndarray:
        """Start position (m)."""
        return self._array("r0", lambda: np.array(self._states[0]))

    @property
    def v0(self) -> np.ndarray:
        """Start velocity (m/s)."""
        return self._array("v0", lambda: np.array(self._states[1]))

    @property
    def a0(self) -> np.ndarray:
        """Start acceleration (m/s^2)."""
        return self._array("a0", lambda: np.array(self._states[2]))

    @property
    def rf(self) -> np.ndarray:
        """Target position (m)."""
        return self._array("rf", lambda: np.array(self._states[3]))

    @property
    def vf(self) -> np.ndarray:
        """Target velocity (m/s)."""
        return self._array("vf", lambda: np.array(self._states[4]))

    @property
    def af(self) -> np.ndarray:
        """Target acceleration (m/s^2)."""
        return self._array("af", lambda: np.array(self._states[5]))

    @property
    def coefficients(self) -> np.ndarray:
        """Polynomial coefficients of the position, shape (6, 3): row i multiplies ``t**i``."""
        return self._array("c", lambda: np.array(self._rows[0][::-1]))

    def _deriv(self, order: int) -> np.ndarray:
        # Coefficients of the order-th derivative, row i multiplying t^i (vectorised evaluation).
        return self._array(f"d{order}", lambda: np.array(self._rows[order][::-1]))

    def _eval(self, t: float | Sequence[float] | np.ndarray, order: int) -> np.ndarray:
        T = self.duration_s
        if isinstance(t, (float, int, np.floating, np.integer)):
            tf = float(t)
            if 0.0 <= tf <= T:
                x = y = z = 0.0
                for cx, cy, cz in self._rows[order]:
                    x = x * tf + cx
                    y = y * tf + cy
                    z = z * tf + cz
                return np.array([x, y, z])
        t_arr = np.asarray(t, dtype=float)
        tc = np.clip(t_arr, 0.0, T)[..., None]
        d = self._deriv(order)
        out = np.zeros((*t_arr.shape, 3))
        for i in range(len(d) - 1, -1, -1):
            out = out * tc + d[i]
        outside = (t_arr < 0.0) | (t_arr > T)
        if np.any(outside):
            out = np.where(outside[..., None], self._extrapolate(t_arr, order), out)
        return out

    def _extrapolate(self, t_arr: np.ndarray, order: int) -> np.ndarray:
        before = (t_arr < 0.0)[..., None]
        r: np.ndarray = np.where(before, self.r0, self.rf)
        v: np.ndarray = np.where(before, self.v0, self.vf)
        a: np.ndarray = np.where(before, self.a0, self.af)
        dt: np.ndarray = np.where(t_arr < 0.0, t_arr, t_arr - self.duration_s)[..., None]
        if order == 0:
            return np.asarray(r + v * dt + a * (dt * dt / 2.0))
        if order == 1:
            return np.asarray(v + a * dt)
        if order == 2:
            return a + 0.0 * dt
        return np.zeros(np.broadcast_shapes(dt.shape, (3,)))

    def sample_floats(self, t_s: float) -> tuple[Vec3f, Vec3f, Vec3f]:
        """Position, velocity and acceleration at ``t_s`` clamped to ``[0, duration_s]``, as plain float tuples.

        The per-tick form (a control loop evaluates one sample of its leg every tick): the same Horner sums as
        :meth:`position`, :meth:`velocity` and :meth:`acceleration` inside the interval, bit for bit, without a
        numpy array per call (``benchmarks/bench_motion.py``). Unlike them it holds the end states outside the
        interval instead of extrapolating.
        """
        T = self.duration_s
        t = t_s
        if t < 0.0:  # noqa: PLR1730 (no min/max call: one sample per control tick)
            t = 0.0
        if t > T:  # noqa: PLR1730
            t = T
        (p5, p4, p3, p2, p1, p0), (v5, v4, v3, v2, v1), (a5, a4, a3, a2) = self._rows[:3]
        return (
            (
                ((((p5[0] * t + p4[0]) * t + p3[0]) * t + p2[0]) * t + p1[0]) * t + p0[0],
                ((((p5[1] * t + p4[1]) * t + p3[1]) * t + p2[1]) * t + p1[1]) * t + p0[1],
                ((((p5[2] * t + p4[2]) * t + p3[2]) * t + p2[2]) * t + p1[2]) * t + p0[2],
            ),
            (
                (((v5[0] * t + v4[0]) * t + v3[0]) * t + v2[0]) * t + v1[0],
                (((v5[1] * t + v4[1]) * t + v3[1]) * t + v2[1]) * t + v1[1],
                (((v5[2] * t + v4[2]) * t + v3[2]) * t + v2[2]) * t + v1[2],
            ),
            (
                ((a5[0] * t + a4[0]) * t + a3[0]) * t + a2[0],
                ((a5[1] * t + a4[1]) * t + a3[1]) * t + a2[1],
                ((a5[2] * t + a4[2]) * t + a3[2]) * t + a2[2],
            ),
        )

    def position(self, t: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Position in metres at ``t`` seconds since the start."""
        return self._eval(t, 0)

    def velocity(self, t: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Velocity in m/s at ``t`` seconds since the start."""
        return self._eval(t, 1)

    def acceleration(self, t: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Acceleration in m/s^2 at ``t`` seconds since the start."""
        return self._eval(t, 2)

    def jerk(self, t: float | Sequence[float] | np.ndarray) -> np.ndarray:
        """Jerk in m/s^3 at ``t`` seconds since the start."""
        return self._eval(t, 3)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration at ``t`` (each shape (3,))."""
        return self.position(t), self.velocity(t), self.acceleration(t)

    def cost(self) -> float:
        """The paper's cost ``1/2 * integral_0^T |jerk|^2 dt`` (exact: 3-point Gauss-Legendre on a quartic)."""
        nodes, weights = np.polynomial.legendre.leggauss(3)
        half = self.duration_s / 2.0
        j = self.jerk(half * (nodes + 1.0))
        return float(0.5 * half * np.sum(weights * np.sum(j * j, axis=1)))

    def replan(
        self,
        r: ArrayLike3,
        v: ArrayLike3,
        a: ArrayLike3,
        t_go_s: float,
        *,
        min_t_go_s: float = MIN_T_GO_S,
    ) -> MinJerk:
        """A new trajectory from the current state ``(r, v, a)`` to the same target over the remaining time.

        This is the paper's guidance law: the quintic is re-solved with ``t_go = t_f - t`` at each control step,
        so disturbances are absorbed instead of accumulating. ``t_go_s`` is floored at ``min_t_go_s`` because
        the coefficients scale like ``1/t_go^5``; below the floor the new trajectory simply arrives a bit later.

        Args:
            r, v, a: current position (m), velocity (m/s), acceleration (m/s^2).
            t_go_s: remaining time to the target (s); may be zero or negative once the deadline has passed.
            min_t_go_s: floor on the horizon (s), positive.
        """
        if not (math.isfinite(min_t_go_s) and min_t_go_s > 0.0):
            raise PlanningError(f"min-jerk min_t_go_s must be positive and finite, got {min_t_go_s!r}")
        t_go = float(t_go_s)
        if math.isnan(t_go):
            raise PlanningError("min-jerk t_go_s is NaN")
        _, _, _, rf, vf, af = self._states
        return MinJerk(r, v, a, rf, vf, af, max(t_go, min_t_go_s))

    def __repr__(self) -> str:
        return (
            f"MinJerk(r0={self.r0.tolist()}, v0={self.v0.tolist()}, a0={self.a0.tolist()}, rf={self.rf.tolist()}, "
            f"vf={self.vf.tolist()}, af={self.af.tolist()}, duration_s={self.duration_s})"
        )


def paper_coefficients(
    r0: ArrayLike3,
    v0: ArrayLike3,
    a0: ArrayLike3,
    rf: ArrayLike3,
    vf: ArrayLike3,
    af: ArrayLike3,
    t_go_s: float,
    *,
    as_printed: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The coefficients ``(c1, c2, c3)`` of the paper's quintic in ``t_go``.

    ``r(t_go) = c3 t_go^5 + c2 t_go^4 + c1 t_go^3 + af t_go^2/2 - vf t_go + rf``. With ``as_printed=True``, ``c2``
    uses the paper's printed ``+Z_a0 / t_go^2`` term, which violates ``r(t_go = T) = r0`` whenever ``a0 != af``;
    the default gives the corrected ``-Z_a0 / t_go^2``. Kept for the record and for the test that shows the error.
    """
    r0_, v0_, a0_, rf_, vf_, af_ = (np.asarray(x, dtype=float) for x in (r0, v0, a0, rf, vf, af))
    T = float(t_go_s)
    z_r0 = r0_ - rf_ + vf_ * T - 0.5 * af_ * T * T
    z_v0 = v0_ - vf_ + af_ * T
    z_a0 = a0_ - af_
    c1 = 10.0 / T**3 * z_r0 + 4.0 / T**2 * z_v0 + 1.0 / (2.0 * T) * z_a0
    c2 = -15.0 / T**4 * z_r0 - 7.0 / T**3 * z_v0 + (1.0 if as_printed else -1.0) / T**2 * z_a0
    c3 = 6.0 / T**5 * z_r0 + 3.0 / T**4 * z_v0 + 1.0 / (2.0 * T**3) * z_a0
    return c1, c2, c3
