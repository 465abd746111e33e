"""Tracking from Python gives the same trajectory as the `desslam run --deterministic` program,
on the synthetic room and on the ../shared fr1_xyz clip."""

import os
import pathlib
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import desslam
from conftest import SYNTHETIC_FRAMES, run_program


def track_in_python(sequence, config, frames=None, transform=None):
    """Tracks the sequence as `desslam run` does; `transform(frame)` -> (bgr, depth, kwargs)."""
    dataset = desslam.TumDataset(sequence)
    results = []
    with desslam.Slam(config, deterministic=True) as slam:
        for i in range(frames or len(dataset)):
            f = dataset.load(i, config)
            bgr, depth, kwargs = transform(f) if transform else (f.bgr, f.depth, {})
            results.append(slam.track(f.timestamp, bgr, depth, f.depth_time_offset, f.image_name, **kwargs))
    return slam, results


def assert_same_trajectory(trajectory, program_file, tmp_path):
    """Same timestamps; poses equal to the file's nine decimals, and written by the same writer
    the program uses, read back equal to 1e-12 (the same doubles up to the text's rounding)."""
    program = desslam.read_tum_trajectory(program_file)
    assert len(trajectory) == len(program) > 0
    np.testing.assert_array_equal(trajectory.timestamps, program.timestamps)
    np.testing.assert_allclose(trajectory.poses, program.poses, rtol=0, atol=1e-8)
    desslam.write_tum_trajectory(tmp_path / "python.txt", trajectory)
    again = desslam.read_tum_trajectory(tmp_path / "python.txt")
    np.testing.assert_array_equal(again.timestamps, program.timestamps)
    np.testing.assert_allclose(again.poses, program.poses, rtol=0, atol=1e-12)


@pytest.fixture(scope="module")
def synthetic_python_run(synthetic):
    sequence, config_file = synthetic
    return track_in_python(sequence, desslam.Config.from_yaml(config_file))


def test_synthetic_room_same_trajectory_as_the_program(synthetic_python_run, synthetic_program_run, tmp_path):
    slam, _ = synthetic_python_run
    trajectory = slam.trajectory()
    assert len(trajectory) >= 0.95 * SYNTHETIC_FRAMES
    assert_same_trajectory(trajectory, synthetic_program_run / "CameraTrajectory.txt", tmp_path)
    keyframes = slam.keyframe_trajectory()
    assert_same_trajectory(keyframes, synthetic_program_run / "KeyFrameTrajectory.txt", tmp_path)


def test_every_frame_gets_its_pose_and_state(synthetic_python_run):
    slam, results = synthetic_python_run
    assert len(results) == SYNTHETIC_FRAMES == slam.frames_processed
    assert results[0].new_map and results[0].keyframe  # the static room starts the map at once
    tracked = [r for r in results if r.state == desslam.TrackingState.TRACKING]
    assert len(tracked) >= 0.95 * SYNTHETIC_FRAMES
    for r in tracked:
        assert r.has_pose and r.map_id == 0
        assert r.T_w_c.dtype == np.float64 and r.T_w_c.shape == (4, 4)
        np.testing.assert_allclose(r.T_w_c[3], [0, 0, 0, 1])
        np.testing.assert_allclose(r.T_w_c[:3, :3] @ r.T_w_c[:3, :3].T, np.eye(3), atol=1e-9)
    assert all(r.inliers > 0 for r in tracked[1:])
    statistics = slam.statistics()
    assert statistics["counts"]["frames"] == SYNTHETIC_FRAMES
    assert statistics["counts"]["frames_tracked"] == len(tracked)
    everything = slam.trajectory_all()
    assert len(everything) >= len(slam.trajectory()) and set(everything.world_map_ids) == {0}
    # One map, never moved into another world: the odometry frame starts as that map's world and
    # stays with it (within what local bundle adjustment moves a frame's keyframes between frames).
    odometry = slam.odometry_trajectory()
    posed = [r for r in results if r.has_pose]
    assert len(odometry) == len(posed) and set(odometry.world_map_ids) == {-1}
    for r, T_odom_c in zip(posed, odometry.poses):
        np.testing.assert_allclose(r.T_odom_c, T_odom_c)
        assert np.linalg.norm(r.T_odom_c[:3, 3] - r.T_w_c[:3, 3]) < 0.02


def test_raw_depth_and_rgb_order_give_the_same_poses(synthetic):
    """uint16 depth (scaled by camera.depth_factor) and RGB-ordered, non-contiguous colour views
    (rgb=True) track exactly as float metres and BGR do."""
    sequence, config_file = synthetic
    config = desslam.Config.from_yaml(config_file)
    factor = config.to_dict()["camera"]["depth_factor"]
    frames = 20
    _, reference = track_in_python(sequence, config, frames)
    _, converted = track_in_python(
        sequence, config, frames,
        lambda f: (f.bgr[:, :, ::-1], np.rint(f.depth * factor).astype(np.uint16), {"rgb": True}))
    assert [r.state for r in converted] == [r.state for r in reference]
    assert sum(r.has_pose for r in reference) >= frames - 1
    for a, b in zip(reference, converted):
        np.testing.assert_allclose(a.T_w_c, b.T_w_c, rtol=0, atol=1e-9)


def test_track_releases_the_gil(synthetic):
    """Another Python thread runs while track() works (tracking must not stall the interpreter)."""
    sequence, config_file = synthetic
    config = desslam.Config.from_yaml(config_file)
    dataset = desslam.TumDataset(sequence)
    frames = [dataset.load(i, config) for i in range(5)]
    stamps, stop = [], threading.Event()

    def tick():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.0002)

    ticker = threading.Thread(target=tick)
    ticker.start()
    inside = 0
    try:
        with desslam.Slam(config, deterministic=True) as slam:
            for f in frames:
                start = time.perf_counter()
                slam.track(f.timestamp, f.bgr, f.depth, f.depth_time_offset, f.image_name)
                end = time.perf_counter()
                # Ticks well inside the call: impossible while the call holds the GIL.
                inside += sum(start + 0.002 < s < end - 0.002 for s in list(stamps))
    finally:
        stop.set()
        ticker.join()
    assert inside > 0, "no other Python thread ran while track() worked: the GIL was held"


def test_readme_example_tracks_the_synthetic_room(synthetic, source_dir, tmp_path):
    sequence, config_file = synthetic
    example = source_dir / "python" / "examples" / "track_sequence.py"
    # The package this test imported, by absolute path (the example runs in another folder).
    env = dict(os.environ, PYTHONPATH=str(pathlib.Path(desslam.__file__).resolve().parents[1]))
    result = subprocess.run([sys.executable, str(example), str(sequence), str(config_file)], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert f"of {SYNTHETIC_FRAMES} frames in the main map" in result.stdout
    assert "ATE [m]" in result.stdout
    assert len(desslam.read_tum_trajectory(tmp_path / "CameraTrajectory.txt")) >= 0.95 * SYNTHETIC_FRAMES


def test_fr1_xyz_clip_same_trajectory_as_the_program(fr1_xyz_clip, source_dir, desslam_binary, tmp_path):
    config_file = source_dir / "config" / "tum_fr1.yaml"
    out = run_program(desslam_binary, fr1_xyz_clip, config_file, tmp_path / "program", "--set", "dense.enabled=false")
    config = desslam.Config.from_yaml(config_file).set("dense.enabled=false")
    slam, results = track_in_python(fr1_xyz_clip, config)
    assert sum(r.has_pose for r in results) >= 0.95 * len(results)
    assert_same_trajectory(slam.trajectory(), out / "CameraTrajectory.txt", tmp_path)
