"""``masonry estimate``, ``masonry markers`` and ``masonry calibrate`` through typer's CliRunner."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from masonry.blueprint import MarkerSpec
from masonry.cli import app
from masonry.perception.aruco import detect_markers, yaw_about_rad
from masonry.perception.calibration import ChessboardSpec, read_calibration, write_calibration
from masonry.perception.render import RenderedBrick, look_down, render_frame
from masonry.perception.types import CameraIntrinsics

runner = CliRunner()
INTR = CameraIntrinsics(600.0, 600.0, 319.5, 239.5)
K_ARG = "600,600,319.5,239.5"
MARKERS = MarkerSpec()
BRICKS = [RenderedBrick(3, (0.05, -0.1, 0.05), 0.5), RenderedBrick(8, (-0.2, 0.12, 0.05), -1.2)]


def frame(
    seed: int, hidden: frozenset[int] = frozenset(), tilt: float = 0.002
) -> tuple[np.ndarray, np.ndarray]:
    T = look_down((0.0, 0.0, 1.3), yaw_rad=0.2, tilt_rad=tilt, tilt_azimuth_rad=seed)
    return T, render_frame(INTR, T, BRICKS, MARKERS, rng=seed, hidden_markers=hidden)


def write_frames(tmp_path: Path, n: int) -> tuple[list[str], list[np.ndarray]]:
    paths, poses = [], []
    for i in range(n):
        T, image = frame(i)
        p = tmp_path / f"img_{i:03d}.png"
        cv2.imwrite(str(p), image)
        paths.append(str(p))
        poses.append(T)
    return paths, poses


def expected(T: np.ndarray, brick: RenderedBrick) -> tuple[np.ndarray, float]:
    R_cw = T[:3, :3].T
    top = np.asarray(brick.position_m) + np.array([0.0, 0.0, 0.05])
    x_cam = R_cw @ np.array([math.cos(brick.yaw_rad), math.sin(brick.yaw_rad), 0.0])
    return R_cw @ (top - T[:3, 3]), yaw_about_rad(x_cam)


def test_estimate_json_lines(tmp_path: Path) -> None:
    paths, poses = write_frames(tmp_path, 3)
    res = runner.invoke(app, ["estimate", *paths, "--intrinsics", K_ARG, "--format", "json"])
    assert res.exit_code == 0, res.output
    lines = res.stdout.strip().splitlines()
    assert len(lines) == 3
    for n, (line, path, T) in enumerate(zip(lines, paths, poses)):
        record = json.loads(line)
        assert list(record) == ["frame", "bricks"]
        assert record["frame"] == path
        assert [b["id"] for b in record["bricks"]] == [3, 8]
        for b, truth in zip(record["bricks"], BRICKS):
            assert list(b) == ["id", "center", "yaw", "tags", "confidence"]
            assert b["tags"] == [2 * truth.brick_id, 2 * truth.brick_id + 1]
            centre, yaw = expected(T, truth)
            assert np.linalg.norm(np.array(b["center"]) - centre) < 0.003
            assert abs(b["yaw"] - yaw) < math.radians(0.5)
            if n == 0:
                assert b["confidence"] is None  # the window holds one estimate
            else:
                assert 0.0 <= b["confidence"] <= 1.0
    # Frames differ only in a few milliradians of tilt: the window is tight, the confidence high.
    assert json.loads(lines[-1])["bricks"][0]["confidence"] > 0.75
    assert lines[0].startswith('{"frame": ') and '"confidence": null' in lines[0]


def test_estimate_text_and_one_hidden_marker(tmp_path: Path) -> None:
    _, image = frame(5, hidden=frozenset({6}))
    p = tmp_path / "one.png"
    cv2.imwrite(str(p), image)
    res = runner.invoke(app, ["estimate", str(p), "--intrinsics", K_ARG])
    assert res.exit_code == 0, res.output
    assert re.search(r"brick 3 at .* tags 7 confidence -", res.stdout)
    assert re.search(r"brick 8 at .* tags 16,17 confidence -", res.stdout)


def test_estimate_video_frames_are_indexed(tmp_path: Path) -> None:
    video = tmp_path / "flight.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480))
    assert writer.isOpened()
    for i in range(4):
        writer.write(cv2.cvtColor(frame(i)[1], cv2.COLOR_GRAY2BGR))
    writer.release()
    res = runner.invoke(app, ["estimate", str(video), "--intrinsics", K_ARG, "--format", "json"])
    assert res.exit_code == 0, res.output
    records = [json.loads(line) for line in res.stdout.strip().splitlines()]
    assert [r["frame"] for r in records] == [0, 1, 2, 3]
    assert all([b["id"] for b in r["bricks"]] == [3, 8] for r in records)
    assert records[-1]["bricks"][1]["confidence"] is not None
    limited = runner.invoke(
        app, ["estimate", str(video), "--intrinsics", K_ARG, "--format", "json", "--frames", "2"]
    )
    assert len(limited.stdout.strip().splitlines()) == 2


def test_estimate_with_calibration_file_and_up(tmp_path: Path) -> None:
    paths, _ = write_frames(tmp_path, 1)
    cal = tmp_path / "camera.yaml"
    write_calibration(cal, INTR)
    res = runner.invoke(app, ["estimate", paths[0], "--calibration", str(cal), "--format", "json"])
    flipped = runner.invoke(
        app, ["estimate", paths[0], "--calibration", str(cal), "--format", "json", "--up", "0,0,-1"]
    )
    assert res.exit_code == 0 and flipped.exit_code == 0, res.output + flipped.output
    a = json.loads(res.stdout)["bricks"][0]
    b = json.loads(flipped.stdout)["bricks"][0]
    assert a["center"] == b["center"]
    assert math.isclose(math.remainder(a["yaw"] + b["yaw"], math.tau), 0.0, abs_tol=1e-4)


def test_estimate_with_distortion_option(tmp_path: Path) -> None:
    dist = (-0.2, 0.05, 0.0, 0.0, 0.0)
    intr = CameraIntrinsics(600.0, 600.0, 319.5, 239.5, distortion=dist)
    T = look_down((0.0, 0.0, 1.3), yaw_rad=0.2)
    p = tmp_path / "d.png"
    cv2.imwrite(str(p), render_frame(intr, T, BRICKS, MARKERS, rng=0))
    res = runner.invoke(
        app,
        ["estimate", str(p), "--intrinsics", K_ARG, "--distortion", "-0.2,0.05,0,0,0", "--format", "json"],
    )
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)["bricks"][1]
    assert np.linalg.norm(np.array(got["center"]) - expected(T, BRICKS[1])[0]) < 0.004


def error_of(args: list[str]) -> tuple[int, str]:
    res = runner.invoke(app, args)
    assert "Traceback" not in res.output
    return res.exit_code, res.stderr.strip()


def test_unreadable_image_is_one_clear_line(tmp_path: Path) -> None:
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"this is not a png")
    code, err = error_of(["estimate", str(bad), "--intrinsics", K_ARG])
    assert code == 2
    assert err == f"error: {bad}: cannot read the image (not an image file, or an unsupported format)"
    code, err = error_of(["estimate", str(tmp_path / "missing.png"), "--intrinsics", K_ARG])
    assert code == 2 and "missing.png: no such file" in err and len(err.splitlines()) == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--intrinsics", "600,600,320"], "--intrinsics: expected fx,fy,cx,cy"),
        (["--intrinsics", "a,b,c,d"], "--intrinsics: expected fx,fy,cx,cy"),
        (["--intrinsics", "-600,600,320,240"], "fx and fy must be > 0"),
        (["--intrinsics", "600,600,320,nan"], "--intrinsics: expected"),
        (["--intrinsics", K_ARG, "--distortion", "0.1,0.2"], "--distortion: expected"),
        ([], "give the camera: --intrinsics fx,fy,cx,cy or --calibration FILE"),
        (["--intrinsics", K_ARG, "--up", "0,0,0"], "--up: the vector must not be zero"),
        (["--intrinsics", K_ARG, "--format", "xml"], "--format must be text or json"),
    ],
)
def test_bad_intrinsics_and_options(tmp_path: Path, args: list[str], message: str) -> None:
    paths, _ = write_frames(tmp_path, 1)
    code, err = error_of(["estimate", paths[0], *args])
    assert code == 2 and message in err and err.startswith("error: ") and len(err.splitlines()) == 1


def test_bad_calibration_file(tmp_path: Path) -> None:
    paths, _ = write_frames(tmp_path, 1)
    cal = tmp_path / "cam.yaml"
    cal.write_text("%YAML:1.0\nimage_width: 640\n")
    code, err = error_of(["estimate", paths[0], "--calibration", str(cal)])
    assert code == 2 and err == f"error: {cal}: no camera_matrix (3x3) in the file"


@pytest.mark.parametrize("name", ["DICT_4X4_51", "APRILTAG"])
def test_unknown_dictionary(tmp_path: Path, name: str) -> None:
    paths, _ = write_frames(tmp_path, 1)
    code, err = error_of(["estimate", paths[0], "--intrinsics", K_ARG, "--dictionary", name])
    assert code == 2 and f"unknown ArUco dictionary '{name}'" in err
    code, err = error_of(["markers", "--bricks", "0", "-o", str(tmp_path / "m.pdf"), "--dictionary", name])
    assert code == 2 and "unknown ArUco dictionary" in err


def test_no_input(tmp_path: Path) -> None:
    code, err = error_of(["estimate", "--intrinsics", K_ARG])
    assert code == 2 and "give INPUT image files, a video file, or --camera INDEX" in err


def test_markers_pdf_is_true_scale(tmp_path: Path) -> None:
    out = tmp_path / "sheets.pdf"
    res = runner.invoke(app, ["markers", "--bricks", "0-2,5", "-o", str(out)])
    assert res.exit_code == 0, res.output
    data = out.read_bytes()
    boxes = re.findall(rb"/MediaBox \[\s*0 0 ([0-9.]+) ([0-9.]+)\s*\]", data)
    assert len(boxes) == 4  # one page per brick
    for w, h in boxes:  # A4 landscape in points (1/72 inch)
        assert float(w) == pytest.approx(297 / 25.4 * 72, abs=0.01)
        assert float(h) == pytest.approx(210 / 25.4 * 72, abs=0.01)


def test_markers_png_measures_true(tmp_path: Path) -> None:
    out = tmp_path / "brick.png"
    res = runner.invoke(app, ["markers", "--bricks", "4", "-o", str(out), "--dpi", "150"])
    assert res.exit_code == 0, res.output
    image = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    px_per_m = 150 / 0.0254
    assert abs(image.shape[0] - 0.210 * px_per_m) < 1.0 and abs(image.shape[1] - 0.297 * px_per_m) < 1.0
    found = {m.marker_id: m.corners_px for m in detect_markers(image, MARKERS)}
    assert set(found) == {8, 9}
    side = np.linalg.norm(found[8][1] - found[8][0])
    assert side == pytest.approx(0.05 * px_per_m, abs=1.5)
    plus, minus = found[8].mean(axis=0), found[9].mean(axis=0)
    assert plus[0] - minus[0] == pytest.approx(0.175 * px_per_m, abs=1.5)  # 2k on the +x side (page right)
    assert abs(plus[1] - minus[1]) < 1.0
    assert found[8][0][0] < found[8][1][0] and found[8][0][1] < found[8][3][1]  # printed upright: TL first


def test_markers_png_several_bricks(tmp_path: Path) -> None:
    res = runner.invoke(app, ["markers", "--bricks", "1,2", "-o", str(tmp_path / "s.png"), "--dpi", "60"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "s-brick1.png").is_file() and (tmp_path / "s-brick2.png").is_file()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--bricks", "5-2"], "runs backwards"),
        (["--bricks", "x"], "--bricks: expected ids like 0-9"),
        (["--bricks", "25"], "brick 25 needs marker ids 50 and 51, but DICT_4X4_50 holds ids 0..49"),
        (["--bricks", "1", "--paper", "a0"], "--paper: unknown paper"),
        (["--bricks", "1", "--spacing", "0.4"], "do not fit"),
    ],
)
def test_markers_errors(tmp_path: Path, args: list[str], message: str) -> None:
    code, err = error_of(["markers", *args, "-o", str(tmp_path / "m.pdf")])
    assert code == 2 and message in err
    code, err = error_of(["markers", "--bricks", "1", "-o", str(tmp_path / "m.svg")])
    assert code == 2 and "must end in .pdf or .png" in err


def test_calibrate_writes_what_estimate_reads(tmp_path: Path) -> None:
    from test_calibration import TRUE, views

    board = ChessboardSpec(9, 6, 0.025)
    paths = []
    for name, image in views(board)[:6]:
        p = tmp_path / name
        cv2.imwrite(str(p), image)
        paths.append(str(p))
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 128, np.uint8))
    out = tmp_path / "camera.yaml"
    res = runner.invoke(
        app, ["calibrate", *paths, str(blank), "--board", "chessboard:9x6:0.025", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "board found in 6 of 7 images" in res.stdout and "skipped" in res.stdout
    intr = read_calibration(out)
    assert intr.fx == pytest.approx(TRUE.fx, rel=0.02)
    paths2, _ = write_frames(tmp_path, 1)
    ok = runner.invoke(app, ["estimate", paths2[0], "--calibration", str(out), "--format", "json"])
    assert ok.exit_code == 0 and json.loads(ok.stdout)["bricks"]


def test_calibrate_errors(tmp_path: Path) -> None:
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 128, np.uint8))
    code, err = error_of(["calibrate", str(blank), "--board", "chess:9x6", "-o", str(tmp_path / "c.yaml")])
    assert code == 2 and "--board: expected chessboard:COLSxROWS:SQUARE_M" in err
    code, err = error_of(["calibrate", str(blank), "-o", str(tmp_path / "c.yaml")])
    assert code == 2 and "found in 0 of 1 images" in err
    junk = tmp_path / "junk.jpg"
    junk.write_text("nope")
    code, err = error_of(["calibrate", str(junk), "-o", str(tmp_path / "c.yaml")])
    assert code == 2 and "junk.jpg: cannot read the image" in err


def test_missing_camera_is_one_clear_line(tmp_path: Path) -> None:
    code, err = error_of(["estimate", "--camera", "57", "--intrinsics", K_ARG])
    assert code == 1 and err == "error: camera 57: cannot open it (is it connected and free?)"
    paths, _ = write_frames(tmp_path, 1)
    code, err = error_of(["estimate", paths[0], "--camera", "0", "--intrinsics", K_ARG])
    assert code == 2 and "either INPUT files or --camera INDEX" in err


def test_video_must_be_alone_and_readable(tmp_path: Path) -> None:
    paths, _ = write_frames(tmp_path, 1)
    fake = tmp_path / "clip.mp4"
    fake.write_bytes(b"\x00" * 64)
    code, err = error_of(["estimate", str(fake), "--intrinsics", K_ARG])
    assert code == 2 and "clip.mp4" in err and len(err.splitlines()) == 1
    code, err = error_of(["estimate", str(fake), paths[0], "--intrinsics", K_ARG])
    assert code == 2 and "a video must be the only INPUT" in err
