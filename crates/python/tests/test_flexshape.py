"""The Python package against the simulator's ground truth and bad input.

Run by `cargo test --release` (tests/pytest.rs builds a package of the freshly built module in
a temporary folder and runs pytest on this file in a virtual environment with NumPy).
"""

import json
import os
import runpy
from pathlib import Path

import numpy as np
import pytest

import flexshape


@pytest.fixture(scope="module")
def sim():
    return flexshape.Simulator(seed=3)


def distance_to_curve(points, curve):
    """Each point's distance (mm) to the nearest point of a densely sampled curve."""
    d = np.linalg.norm(points[:, None, :] - curve[None, :, :], axis=2)
    return d.min(axis=1)


def test_tracking_own_frames_matches_the_truth(sim):
    tracker = flexshape.Tracker(sim.rig, sim.backgrounds())
    assert tracker.follows
    starts = []
    for n, pose in enumerate(sim.motion(6, rate_hz=120.0)):
        frame = sim.render(n, pose)
        record = tracker.process(frame.images)
        assert record.frame == n
        assert record.status == "ok" and record.ok and record.reason is None, record
        assert record.centerline.dtype == np.float64
        assert record.centerline.ndim == 2 and record.centerline.shape[1] == 3
        assert record.curvature.shape == (record.centerline.shape[0],)
        assert np.linalg.norm(record.tip - frame.truth_tip) < 0.3
        off = distance_to_curve(record.centerline, frame.truth_centerline)
        assert np.median(off) < 0.1 and off.max() < 0.5, (np.median(off), off.max())
        assert len(record.bands) == len(frame.truth()["bands"])
        starts.append(record.to_dict()["start"])
    # The first frame starts from its hull; the others follow the shape before them.
    assert starts[0] == "hull" and all(s != "hull" for s in starts[1:]), starts


def test_frames_carry_the_times_they_are_given(sim):
    tracker = flexshape.Tracker(sim.rig, sim.backgrounds())
    for n, pose in enumerate(sim.motion(3, rate_hz=120.0)):
        frame = sim.render(n, pose)
        at = 100.0 + n / 120.0
        record = tracker.process(frame.images, captured_s=at, camera_captured_s=[at, at, at])
        assert record.ok, record
        d = record.to_dict()
        assert d["captured_s"] == at and d["captured_from"] == "given"
        assert d["camera_captured_s"] == [at, at, at]
    # Untimed frames carry no time; a camera's time missing or not a number is refused.
    assert "captured_s" not in tracker.process(frame.images).to_dict()
    with pytest.raises(ValueError, match="camera_captured_s"):
        tracker.process(frame.images, captured_s=1.0, camera_captured_s=[1.0, 1.0])
    with pytest.raises(ValueError, match="captured_s=NaN"):
        tracker.process(frame.images, captured_s=float("nan"))


def test_opencv_images_in_bgr_order_give_the_same_record(sim):
    frame = sim.render(0, sim.sweep(1)[0])
    rgb = flexshape.Tracker(sim.rig, sim.backgrounds(), follow=False).process(frame.images)
    bgr = [np.ascontiguousarray(i[:, :, ::-1]) for i in frame.images]
    backgrounds = [np.ascontiguousarray(i[:, :, ::-1]) for i in sim.backgrounds()]
    tracker = flexshape.Tracker(sim.rig, backgrounds, follow=False, channels="bgr")
    same = tracker.process(bgr, channels="bgr")
    assert rgb.ok and np.array_equal(rgb.centerline, same.centerline)
    with pytest.raises(ValueError, match="channels"):
        tracker.process(bgr, channels="rgba")


def test_a_strided_image_gives_the_same_record(sim):
    pose = sim.sweep(1)[0]
    frame = sim.render(0, pose)
    a = flexshape.Tracker(sim.rig, sim.backgrounds(), follow=False).process(frame.images)
    fortran = [np.asfortranarray(i) for i in frame.images]
    b = flexshape.Tracker(sim.rig, sim.backgrounds(), follow=False).process(fortran)
    assert np.array_equal(a.centerline, b.centerline)


def test_an_empty_scene_is_not_ok(sim):
    tracker = flexshape.Tracker(sim.rig, sim.backgrounds())
    record = tracker.process(sim.backgrounds())
    assert not record.ok and record.status != "ok"
    assert record.tip is None and record.centerline.shape == (0, 3)


def test_recordings_track_stop_and_read_back(tmp_path):
    rec = tmp_path / "rec"
    assert flexshape.simulate(rec, frames=4, seed=2) == 4
    records = flexshape.track(rec, threads=2)
    assert [r.frame for r in records] == [0, 1, 2, 3]
    assert all(r.ok for r in records), records
    seen = []
    stopped = flexshape.track(rec, threads=1, on_record=lambda r: seen.append(r.frame) or len(seen) < 2)
    assert seen == [0, 1] and [r.frame for r in stopped] == [0, 1]
    # The JSON Lines form reads back to the same records.
    lines = tmp_path / "shapes.jsonl"
    lines.write_text("".join(r.json() + "\n" for r in records))
    back = flexshape.read_records(lines)
    assert [r.to_dict() for r in back] == [r.to_dict() for r in records]
    assert json.loads(records[0].json())["frame"] == 0
    # The rig of the recording, and its own tracker.
    rig = flexshape.Rig.open(rec / "rig.toml")
    assert rig.cameras == ["cam0", "cam1", "cam2"]
    tip = records[0].tip
    pixel = rig.project(0, tip[None, :])
    width, height = rig.image_sizes[0]
    assert pixel.shape == (1, 2) and 0 <= pixel[0, 0] < width and 0 <= pixel[0, 1] < height
    tracker = flexshape.Tracker.from_recording(rec, follow=False)
    assert tracker.follows is False
    # Not over an existing recording without overwrite=True, said in Python's terms.
    with pytest.raises(flexshape.FlexshapeError, match="rec") as refused:
        flexshape.simulate(rec, frames=1)
    assert "overwrite=True" in str(refused.value) and "--" not in str(refused.value)
    # Lazily: each record as it is made, the same as track()'s; leaving the loop stops it.
    shape = lambda r: (r.frame, r.status, r.centerline.tolist())  # the rest holds timings
    lazily = []
    for r in flexshape.iter_track(rec, threads=2):
        lazily.append(r)
    assert [shape(r) for r in lazily] == [shape(r) for r in records]
    it = flexshape.iter_track(rec, threads=2)
    first = next(it)
    it.close()
    assert shape(first) == shape(records[0]) and list(it) == []
    with pytest.raises(flexshape.FlexshapeError, match="missing"):
        flexshape.iter_track(tmp_path / "missing")
    # Records pickle whole (multiprocessing sends them so) and rebuild from their JSON.
    import pickle
    assert pickle.loads(pickle.dumps(records[1])) == records[1]
    assert flexshape.Record(records[2].json()).to_dict() == records[2].to_dict()
    with pytest.raises(ValueError, match="json"):
        flexshape.Record("{}")
    # The rig's cameras as OpenCV has them: by name or index, K, D, R, t.
    cam = rig["cam1"]
    assert cam.name == "cam1" and len(rig) == 3 and rig[-2].name == "cam1"
    assert cam.K.shape == (3, 3) and cam.K[2, 2] == 1 and cam.D.shape == (5,)
    assert np.allclose(cam.R @ cam.R.T, np.eye(3)) and cam.t.shape == (3,)
    assert np.allclose(cam.centre, -cam.R.T @ cam.t)
    # Projecting by hand with K, R, t (no distortion at the image centre's ray) agrees.
    X = cam.centre + 500.0 * cam.R.T @ np.linalg.inv(cam.K) @ np.array([cam.K[0, 2], cam.K[1, 2], 1.0])
    assert np.allclose(cam.project(X[None, :]), [[cam.K[0, 2], cam.K[1, 2]]], atol=1e-6)
    assert np.allclose(cam.project(X[None, :]), rig.project(1, X[None, :]))
    assert cam.image_size == rig.image_sizes[1]
    with pytest.raises(KeyError, match="cam0, cam1, cam2"):
        rig["left"]
    with pytest.raises(IndexError, match="3 cameras"):
        rig[3]


def test_bad_input_is_a_clear_error(sim, tmp_path):
    backgrounds = sim.backgrounds()
    with pytest.raises(ValueError, match="one image per camera"):
        flexshape.Tracker(sim.rig, backgrounds[:2])
    tracker = flexshape.Tracker(sim.rig, backgrounds)
    small = [np.zeros((240, 320, 3), np.uint8)] * 3
    with pytest.raises(flexshape.FlexshapeError, match="frame 0"):
        tracker.process(small)
    with pytest.raises(ValueError, match="RGB"):
        tracker.process([np.zeros((480, 640, 4), np.uint8)] * 3)
    # Every wrong array is a ValueError naming it and saying what to give.
    with pytest.raises(ValueError, match=r"images\[1\].*shape \(480, 640\).*grey"):
        tracker.process([np.zeros((480, 640, 3), np.uint8), np.zeros((480, 640), np.uint8)] * 1 + [np.zeros((480, 640, 3), np.uint8)])
    with pytest.raises(ValueError, match=r"images\[0\].*dtype float64.*astype"):
        tracker.process([np.zeros((480, 640, 3))] * 3)
    with pytest.raises(ValueError, match=r"backgrounds\[2\].*got a list"):
        flexshape.Tracker(sim.rig, backgrounds[:2] + [[1, 2, 3]])
    with pytest.raises(flexshape.FlexshapeError, match="missing.toml"):
        flexshape.Rig.open(tmp_path / "missing.toml")
    broken = tmp_path / "broken.jsonl"
    broken.write_text('{"frame": 0}\nnot json\n')
    with pytest.raises(flexshape.FlexshapeError, match="line"):
        flexshape.read_records(broken)
    with pytest.raises(ValueError, match="cameras"):
        sim.rig.project(7, np.zeros((1, 3)))


def test_the_model_experiment_identifies_the_stiffnesses(tmp_path):
    # The paper's catheter with polymer tendons, as the command-line test uses it.
    template = flexshape.model_template()
    assert "stiffness = 14000.0" in template
    params = tmp_path / "params.toml"
    params.write_text(template.replace("stiffness = 14000.0", "stiffness = 1500.0"))
    rec = tmp_path / "rec"
    flexshape.simulate(rec, frames=8, model=params)
    fit = flexshape.fit_model(params, rec)
    report = fit.report()
    # 8 poses and one registration pose per tendon (4), all usable.
    assert report["observations"] == 12 and report["registration_poses"] == 4, report
    assert report["skipped"] == [] and report["reference_pose"] is True
    # The bending stiffnesses within 2 % of the truth the experiment was simulated with
    # (measured −0.02 % and −0.01 %).
    for j in range(2):
        error = report["estimated"][j] / report["nominal"][j] - 1.0
        assert abs(error) < 0.02, (j, error)
    assert "Kx" in str(fit)
    # The model frame as --save-frame writes it: the registered rotation.
    assert fit.model_frame()["rotation"] == report["rotation"]


def shared_data(name):
    """A folder of ../shared/data beside the repository; skipped when absent unless
    FLEXSHAPE_REQUIRE_SHARED=1 (as in CI), which makes it a failure."""
    folder = Path(__file__).resolve().parents[3].parent / "shared" / "data" / name
    if not folder.is_dir():
        if os.environ.get("FLEXSHAPE_REQUIRE_SHARED") == "1":
            pytest.fail(f"{folder} is missing and FLEXSHAPE_REQUIRE_SHARED=1")
        pytest.skip(f"{folder} is missing")
    return folder


def test_a_real_stereo_pair_calibrates_as_opencv_does(tmp_path):
    data = shared_data("stereo-9x6")
    reference = json.loads((data / "opencv-reference.json").read_text())
    calibration = flexshape.calibrate(
        [("left", str(data / "left*.jpg")), ("right", str(data / "right*.jpg"))], "9x6", 1.0
    )
    left, right = calibration.reports()
    assert left["name"] == "left" and len(left["views"]) == 15
    # OpenCV's own: rms 0.128 px, fx 516.55 (square size 1: units of squares).
    assert left["rms_px"] < reference["rms_px"] + 0.01, left["rms_px"]
    assert abs(left["fx"] / reference["fx"] - 1.0) < 0.005, left["fx"]
    assert calibration.rig.cameras == ["left", "right"]
    calibration.write(tmp_path / "rig")
    assert flexshape.Rig.open(tmp_path / "rig" / "rig.toml").cameras == ["left", "right"]
    assert "joint adjustment" in calibration.summary(tmp_path / "rig")


def test_the_example_tracks_and_prints_ten_tips(capsys):
    example = Path(__file__).parent.parent / "examples" / "track_simulated.py"
    runpy.run_path(str(example), run_name="__main__")
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 10 and all(" ok [" in line for line in lines), lines
