"""Shared test configuration: hypothesis is seeded (derandomised) so CI runs are reproducible, and the long
tests start first so that the two xdist workers (pyproject's ``addopts``) finish together.

Under xdist every worker loads the ``ci`` profile: ``derandomize=True`` implies ``database=None``, so the
workers share no example database and each test draws the same examples on whichever worker runs it.
"""

from __future__ import annotations

import os
import signal

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


def pytest_configure(config: pytest.Config) -> None:
    """SIGINT back to Python's default when the shell that started pytest ignored it.

    A shell that runs a command in the background (``pytest &``, a script's ``&``) starts it with SIGINT ignored,
    and every child inherits that: the tests that stop ``masonry sitl`` as Ctrl-C does would then wait on a child
    that cannot hear it. Each xdist worker runs this too (it is a process of its own).
    """
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(autouse=True)
def _strict_triggers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every UAV machine built in a test is strict: a trigger fired from a state without such a transition raises
    ``transitions.MachineError`` and fails the test (in flight such a trigger is ignored: docs/state-machines.md)."""
    from masonry.fsm.model import UavModel

    monkeypatch.setattr(UavModel, "strict_triggers", True)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The ``slow`` tests first (a stable sort: the rest keep their order).

    xdist hands tests out in collection order, so a long mission collected last would run alone on one worker
    while the other has finished: longest first is what lets both end together
    (docs/performance/test-suite.md).
    """
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
