"""Faults: defaults, parsing of the --fault options, and clear errors for bad input."""

from __future__ import annotations

import pytest

from masonry.errors import InputError
from masonry.sim import Faults


def test_defaults_are_off() -> None:
    f = Faults()
    assert not f.any
    assert f.grasp_failure == f.dropout == f.occlusion == f.gusts_mps == 0.0
    assert f.battery_drain_per_s is None
    assert dict(f.link_loss_at_s) == {} and dict(f.uav_loss_at_s) == {}


def test_parse_every_key() -> None:
    f = Faults.parse(
        [
            "grasp=0.3",
            "dropout=0.5",
            "occlusion=0.25",
            "gusts=2.0",
            "battery=0.002",
            "link-loss=glue-1@60",
            "uav-loss=brick-2@120",
            "uav-loss=brick-3@7.5",
        ]
    )
    assert f.grasp_failure == 0.3 and f.dropout == 0.5 and f.occlusion == 0.25
    assert f.gusts_mps == 2.0 and f.battery_drain_per_s == 0.002
    assert dict(f.link_loss_at_s) == {"glue-1": 60.0}
    assert dict(f.uav_loss_at_s) == {"brick-2": 120.0, "brick-3": 7.5}
    assert f.any
    assert f.uav_names() == {"glue-1", "brick-2", "brick-3"}


def test_parse_is_tolerant_of_case_spaces_and_aliases() -> None:
    f = Faults.parse([" GRASP = 0.1 ", "uav_loss=brick-1@5", "gust=1.5"])
    assert f.grasp_failure == 0.1 and f.gusts_mps == 1.5 and dict(f.uav_loss_at_s) == {"brick-1": 5.0}
    assert Faults.parse(["grasp-failure=0.2"]).grasp_failure == 0.2


def test_parse_on_top_of_a_base() -> None:
    base = Faults(gusts_mps=1.0, uav_loss_at_s={"a": 1.0})
    f = Faults.parse(["uav-loss=b@2"], base=base)
    assert f.gusts_mps == 1.0 and dict(f.uav_loss_at_s) == {"a": 1.0, "b": 2.0}


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("grasp", "expected KEY=VALUE"),
        ("=0.3", "expected KEY=VALUE"),
        ("grasp=", "expected KEY=VALUE"),
        ("wind=3", "unknown key 'wind'"),
        ("grasp=abc", "needs a number"),
        ("grasp=1.5", r"probability and must be in \[0, 1\]"),
        ("dropout=-0.1", "probability"),
        ("gusts=-1", "must be >= 0"),
        ("gusts=nan", "finite"),
        ("battery=-0.1", "must be >= 0"),
        ("uav-loss=brick-2", "expects NAME@SECONDS"),
        ("uav-loss=@12", "expects NAME@SECONDS"),
        ("link-loss=brick-1@soon", "needs a number"),
        ("uav-loss=brick-1@-3", "must be >= 0"),
    ],
)
def test_parse_errors_name_the_item_and_the_problem(item: str, message: str) -> None:
    with pytest.raises(InputError, match=message) as info:
        Faults.parse([item])
    assert repr(item.strip()) in str(info.value) or item.strip() in str(info.value)


def test_parse_rejects_a_key_given_twice() -> None:
    with pytest.raises(InputError, match="given twice"):
        Faults.parse(["grasp=0.1", "grasp=0.2"])
    with pytest.raises(InputError, match="given twice for brick-1"):
        Faults.parse(["uav-loss=brick-1@1", "uav-loss=brick-1@2"])


def test_constructor_validates_ranges() -> None:
    with pytest.raises(InputError, match="grasp_failure"):
        Faults(grasp_failure=2.0)
    with pytest.raises(InputError, match="gusts_mps"):
        Faults(gusts_mps=-1.0)
    with pytest.raises(InputError, match="uav_loss_at_s"):
        Faults(uav_loss_at_s={"x": -1.0})


def test_faults_are_frozen_hashable_values() -> None:
    a = Faults.parse(["uav-loss=b@2", "grasp=0.5"])
    b = Faults(grasp_failure=0.5, uav_loss_at_s={"b": 2.0})
    assert a == b and hash(a) == hash(b)
    with pytest.raises(AttributeError):
        a.grasp_failure = 0.1  # type: ignore[misc]
    with pytest.raises(TypeError):
        a.uav_loss_at_s["c"] = 1.0  # type: ignore[index]


def test_check_uavs_names_the_unknown_uav() -> None:
    f = Faults.parse(["uav-loss=brick-9@5"])
    f.check_uavs(["brick-9"])
    with pytest.raises(InputError, match="no UAV named 'brick-9'"):
        f.check_uavs(["brick-1", "glue-1"])
