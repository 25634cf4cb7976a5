"""Shared test configuration: hypothesis is seeded (derandomised) so CI runs are reproducible."""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    derandomize=True,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile(os.environ.get("MASONRY_HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True)
def _strict_triggers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every UAV machine built in a test is strict: a trigger fired from a state without such a transition raises
    ``transitions.MachineError`` and fails the test (in flight such a trigger is ignored: docs/state-machines.md)."""
    from masonry.fsm.model import UavModel

    monkeypatch.setattr(UavModel, "strict_triggers", True)
