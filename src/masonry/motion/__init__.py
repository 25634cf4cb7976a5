"""Pure motion: minimum-jerk trajectories (paper Sec. IV) and the position PID producing velocity references."""

from __future__ import annotations

from masonry.motion.minjerk import MIN_T_GO_S, MinJerk, paper_coefficients
from masonry.motion.pid import PID, AxisGains, PIDGains

__all__ = ["MIN_T_GO_S", "PID", "AxisGains", "MinJerk", "PIDGains", "paper_coefficients"]
