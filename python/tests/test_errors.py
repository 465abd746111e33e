"""Bad input raises with a message that says what is wrong and what is expected."""

import numpy as np
import pytest

import desslam


@pytest.fixture(scope="module")
def slam(synthetic):
    _, config_file = synthetic
    with desslam.Slam(desslam.Config.from_yaml(config_file), deterministic=True) as s:
        yield s


H, W = 480, 640
GREY = np.full((H, W, 3), 128, np.uint8)
ONE_METRE = np.ones((H, W), np.float32)


@pytest.mark.parametrize("bgr, error, message", [
    (np.zeros((H, W, 3), np.float32), TypeError, "uint8"),
    (np.zeros((H, W), np.uint8), ValueError, r"\(H, W, 3\), got \(480, 640\)"),
    (np.zeros((H, W, 4), np.uint8), ValueError, r"\(480, 640, 4\)"),
])
def test_colour_images_of_the_wrong_kind(slam, bgr, error, message):
    with pytest.raises(error, match=message):
        slam.track(0.0, bgr, ONE_METRE)


@pytest.mark.parametrize("depth, error, message", [
    (np.ones((H, W), np.float64), TypeError, "float32 .metres. or uint16.*got dtype float64"),
    (np.ones((H, W), np.int32), TypeError, "float32"),
    (np.ones((H, W, 1), np.float32), ValueError, r"\(H, W\), got \(480, 640, 1\)"),
])
def test_depth_images_of_the_wrong_kind(slam, depth, error, message):
    with pytest.raises(error, match=message):
        slam.track(0.0, GREY, depth)


def test_wrong_size_and_then_a_good_frame(slam):
    with pytest.raises(RuntimeError, match="320x480 but camera.width/height say 640x480"):
        slam.track(0.0, GREY, np.ones((H, W // 2), np.float32))
    # A uniform grey frame has nothing to track: no pose, no map yet.
    r = slam.track(0.0, GREY, ONE_METRE)
    assert r.state == desslam.TrackingState.NOT_INITIALISED and not r.has_pose and r.map_id == -1
    np.testing.assert_array_equal(r.T_w_c, np.eye(4))


def test_bad_run_modes_and_files(synthetic, tmp_path):
    sequence, config_file = synthetic
    with pytest.raises(RuntimeError, match="exclude each other"):
        desslam.Slam(config_file, deterministic=True, realtime=True)
    with pytest.raises(RuntimeError, match=str(tmp_path / "missing")):
        desslam.TumDataset(tmp_path / "missing")
    dataset = desslam.TumDataset(sequence)
    with pytest.raises(RuntimeError, match="has 60 frames"):
        dataset.load(len(dataset), desslam.Config.from_yaml(config_file))
    with pytest.raises(RuntimeError, match="missing.txt"):
        desslam.read_tum_trajectory(tmp_path / "missing.txt")


def test_trajectories_of_the_wrong_shape_or_not_rigid():
    t = np.arange(5, dtype=float)
    poses = np.tile(np.eye(4), (5, 1, 1))
    with pytest.raises(ValueError, match=r"\(N, 4, 4\) with N = 5.*\(5, 3, 4\)"):
        desslam.Trajectory(t, poses[:, :3, :])
    with pytest.raises(ValueError, match="1-D"):
        desslam.Trajectory(t.reshape(5, 1), poses)
    with pytest.raises(ValueError, match=r"map_ids must have shape \(5,\)"):
        desslam.Trajectory(t, poses, map_ids=[0, 0])
    scaled = poses.copy()
    scaled[2, :3, :3] *= 2.0
    with pytest.raises(RuntimeError, match="pose 2 is not a rigid transform"):
        desslam.evaluate(desslam.Trajectory(t, poses), desslam.Trajectory(t, scaled))
    with pytest.raises(TypeError, match="desslam.Trajectory, a TUM trajectory file's path"):
        desslam.evaluate(42, desslam.Trajectory(t, poses))
