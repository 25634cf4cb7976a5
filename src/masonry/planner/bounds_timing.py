"""The timing of the duration bounds: ``TaskTiming`` with the deprecated keywords applied, and its checks."""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

from masonry.errors import PlanningError
from masonry.timing import DEFAULT_TIMING, TaskTiming

#: Keywords the duration functions took before :class:`~masonry.timing.TaskTiming`: old name -> its field.
_LEGACY_FIELDS = {
    "cruise_speed_mps": "cruise_speed_mps",
    "vertical_speed_mps": "vertical_speed_mps",
    "control_period_s": "control_period_s",
    "clearance_m": "clearance_m",
    "settle_time_s": "settle_time_s",
    "min_estimates": "min_estimates",
    "descent_s": "descent_duration_s",
    "grasp_press_m": "grasp_press_m",
    "grasp_dwell_s": "grasp_dwell_s",
    "placement_radius_m": "placement_radius_m",
    "release_dwell_s": "release_dwell_s",
    "stable_time_s": "stable_time_s",
    "spray_descent_s": "spray_descent_s",
    "spray_speed_mps": "spray_speed_mps",
    "close_dwell_s": "close_dwell_s",
    "chain_descent_s": "chain_descent_s",
    "arrive_tolerance_m": "arrive_tolerance_m",
}


def _timing(
    func: str, timing: TaskTiming | None, legacy: dict[str, Any], allowed: tuple[str, ...]
) -> TaskTiming:
    """``timing`` (default: ``UavConfig``'s), with the deprecated keywords ``legacy`` of ``func`` applied.

    ``legacy`` is left with the keywords that are not fields (``leg_peak_factor``, ``min_leg_s``) for the caller.
    """
    base = DEFAULT_TIMING if timing is None else timing
    unknown = sorted(k for k in legacy if k not in allowed)
    if unknown:
        # builtin raise: the TypeError Python raises for an unknown keyword, as the signature had it
        raise TypeError(f"{func}() got an unexpected keyword argument {unknown[0]!r}")
    given = {k: v for k, v in legacy.items() if v is not None}
    legacy.clear()
    if not given:
        return base
    changes: dict[str, Any] = {}
    for key, value in given.items():
        if key == "effector_offset_z_m":
            x, y, _z = base.effector_offset_m
            changes["effector_offset_m"] = (x, y, float(value))
        elif key == "effector_offset_m":
            changes["effector_offset_m"] = (float(value[0]), float(value[1]), float(value[2]))
        elif key in _LEGACY_FIELDS:
            changes[_LEGACY_FIELDS[key]] = value
        else:
            legacy[key] = value
    fields = ", ".join(f"{_LEGACY_FIELDS.get(k, k)}=..." for k in given if k in _LEGACY_FIELDS) or "..."
    warnings.warn(
        f"{func}({', '.join(f'{k}=' for k in given)}) is deprecated: pass timing=, a masonry.timing.TaskTiming "
        f"(UavConfig.timing(), or dataclasses.replace(DEFAULT_TIMING, {fields}))",
        DeprecationWarning,
        stacklevel=3,
    )
    return dataclasses.replace(base, **changes)


def _check_timing(timing: TaskTiming, positive: tuple[str, ...], non_negative: tuple[str, ...]) -> None:
    for name in positive:
        value = getattr(timing, name)
        if not math.isfinite(value) or value <= 0.0:
            raise PlanningError(f"timing.{name} must be finite and > 0, got {value!r}")
    for name in non_negative:
        value = getattr(timing, name)
        if not math.isfinite(value) or value < 0.0:
            raise PlanningError(f"timing.{name} must be finite and >= 0, got {value!r}")
