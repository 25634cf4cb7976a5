"""What the import-linter contracts in pyproject.toml cannot see: which OpenCV calls a module makes.

cv2 is imported by perception (ArUco detection and rendering on images) and by the camera adapter; opening a
device or a video (``cv2.VideoCapture``) is hardware access and belongs to the adapters. The one exception is
``masonry perception estimate``, which reads a video file or a live camera itself.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import masonry

PACKAGE = Path(masonry.__file__).parent
CAPTURE_ALLOWED = {"adapters/camera.py", "cli/perception.py"}


def _captures(path: Path) -> list[int]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and node.attr in {"VideoCapture", "VideoWriter"}
    ]


def test_only_the_camera_adapter_and_the_estimate_command_open_a_capture() -> None:
    found = {
        path.relative_to(PACKAGE).as_posix(): lines
        for path in sorted(PACKAGE.rglob("*.py"))
        if (lines := _captures(path))
    }
    assert found, "the camera adapter opens a VideoCapture: the scan found none, so it is broken"
    outside = {name: lines for name, lines in found.items() if name not in CAPTURE_ALLOWED}
    assert not outside, f"cv2 capture outside the adapters (module: lines): {outside}"


def test_the_scan_sees_a_capture(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("import cv2\n\ndef f():\n    return cv2.VideoCapture(0)\n", encoding="utf-8")
    assert _captures(probe) == [4]


#: mission modules that build or drive the simulation: the only ones allowed to reach the machines and the simulator
SIMULATION_BUILDERS = {"built_truth", "chaos", "remote", "sim_loop", "sim_options", "simulate", "uav_stack"}
RUNTIME_CONTRACT = "Mission control's runtime knows neither the machines nor the simulator"


def test_every_mission_module_is_under_the_runtime_contract_or_named_a_simulation_builder() -> None:
    """A new module under ``mission/`` is held to the runtime's contract unless it is named a builder here: a
    hand-kept list in pyproject.toml had let 26 modules (the reserved airspace, the handler's bases) go unchecked."""
    # read as text: tomllib is 3.11+ and the project supports 3.10
    text = (PACKAGE.parent.parent / "pyproject.toml").read_text(encoding="utf-8")
    block = text.split(f'name = "{RUNTIME_CONTRACT}', 1)[1].split("forbidden_modules", 1)[0]
    listed = re.findall(r'"masonry\.mission\.(\w+)"', block)
    assert listed, "the runtime contract was not found in pyproject.toml: the scan is broken"
    checked = set(listed)
    modules = {p.stem for p in (PACKAGE / "mission").glob("*.py") if p.stem != "__init__"}
    assert not modules - checked - SIMULATION_BUILDERS, "mission modules outside the runtime contract"
    assert not checked & SIMULATION_BUILDERS, "a simulation builder is listed under the runtime contract"
    assert not checked - modules, "the runtime contract names modules that do not exist"
