"""A sample of the bad-input campaign (benchmarks/bad_inputs.py), run in CI through the real console script.

Each case must end in one ``error:`` line on stderr and exit status 2: no traceback, no hang, no nonsense
accepted. The whole campaign (385 cases) is the benchmark; its figures are in docs/reliability.md.
"""

from __future__ import annotations

import pytest

from benchmark_module import benchmark

bad_inputs = benchmark("bad_inputs")

SAMPLE = [
    ("blueprint/plan", "billion laughs in a position"),
    ("blueprint/plan", "duplicate top-level key"),
    ("blueprint/plan", "a FIFO"),
    ("blueprint/plan", "/dev/zero"),
    ("blueprint/plan", "200,000-element position"),
    ("blueprint/plan", "pickup inside the wall"),
    ("blueprint/plan", "UAV name with *"),
    ("blueprint/sim", "brick id 10**26"),
    ("blueprint/sim", "cruise altitude below the wall top"),
    ("blueprint/fly", "two UAVs on one home"),
    ("options", "sim --dt 1e-6"),
    ("options", "sim --brick-uavs x"),
    ("options", "blueprint --placed-courses > --courses"),
    ("options", "fly --wait -1 (mission)"),
    ("outputs", "sim --report into a missing folder"),
    ("journals", "another program's database"),
    ("journals", "resume a journal of the same ids, other geometry"),
    ("configs", "uav.yaml billion laughs"),
    ("configs", "uav.yaml binary"),
    ("configs", "--calibration missing"),
    ("network", "mission-control --zenoh-config unknown key"),
    ("network", "mission-control on all interfaces without a key"),
    ("network", "mission-control --key-file too short"),
]
_CASES = {(c.category, c.name): c for c in bad_inputs.all_cases()}


def test_the_sample_names_real_cases():
    assert [k for k in SAMPLE if k not in _CASES] == []


@pytest.mark.slow
@pytest.mark.parametrize("key", SAMPLE, ids=[f"{c}: {n}" for c, n in SAMPLE])
def test_bad_input_is_one_clean_line(key, tmp_path):
    outcome = bad_inputs.run_case(_CASES[key], tmp_path, time_limit_s=120.0)
    assert outcome.kind == "clean", f"{key}: {outcome.kind}, exit {outcome.status}: {outcome.first_line}"


@pytest.mark.parametrize(
    ("status", "stderr", "timed_out", "kind"),
    [
        (2, "error: bad.yaml: clearance: must be > 0\n", False, "clean"),
        (2, "error: one\nerror: two\n", False, "other"),
        (1, "Traceback (most recent call last):\n  ...\n", False, "traceback"),
        (0, "", False, "accepted"),
        (None, "", True, "hang"),
        (2, "error: " + "x" * 500 + "\n", False, "other"),
    ],
)
def test_the_classifier(status, stderr, timed_out, kind):
    assert bad_inputs.classify(status, "", stderr, timed_out)[0] == kind
