"""The module imports from the build tree, says its version and reads configs."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import desslam


def test_imports_from_the_build_tree_and_gives_the_programs_version(desslam_binary):
    build_python = pathlib.Path(os.environ["PYTHONPATH"].split(os.pathsep)[0]).resolve()
    assert pathlib.Path(desslam.__file__).resolve().parent == build_python / "desslam"
    program = subprocess.run([desslam_binary, "--version"], capture_output=True, text=True, check=True)
    assert desslam.__version__ == desslam.version()
    assert program.stdout.split() == ["desslam", desslam.version()]


def test_config_assignments_are_checked(synthetic):
    _, config_file = synthetic
    config = desslam.Config.from_yaml(config_file)
    assert config.set("tracking.max_depth", "6.5") is config  # chains
    config.set("dense.enabled=true")
    settings = config.to_dict()
    assert settings["tracking"]["max_depth"] == 6.5
    assert settings["dense"]["enabled"] is True
    assert settings["camera"]["width"] == 640
    with pytest.raises(RuntimeError, match="max_depth"):  # "did you mean"
        config.set("tracking.max_depht=3")
    config.set("camera.fx=-1")
    with pytest.raises(RuntimeError, match="camera.fx"):
        config.validate()
    with pytest.raises(RuntimeError, match="/nonexistent/config.yaml"):
        desslam.Config.from_yaml("/nonexistent/config.yaml")


def test_tum_dataset_reads_the_synthetic_sequence(synthetic):
    sequence, config_file = synthetic
    config = desslam.Config.from_yaml(config_file)
    dataset = desslam.TumDataset(sequence)
    assert len(dataset) == len(dataset.timestamps) == len(dataset.rgb_paths) > 0
    np.testing.assert_allclose(dataset.depth_timestamps - dataset.timestamps, 0.005, atol=1e-6)  # sim's offset
    frame = dataset.load(0, config)
    assert frame.bgr.dtype == np.uint8 and frame.bgr.shape == (480, 640, 3)
    assert frame.depth.dtype == np.float32 and frame.depth.shape == (480, 640)
    assert 0.3 < float(np.median(frame.depth[frame.depth > 0])) < 6.0  # metres, inside the 6 x 4 m room
    assert frame.timestamp == dataset.timestamps[0]
    assert frame.depth_time_offset == pytest.approx(0.005, abs=1e-6)
    assert frame.image_name == pathlib.Path(dataset.rgb_paths[0]).name
    gt = dataset.ground_truth
    assert isinstance(gt, desslam.Trajectory) and len(gt) == len(dataset)
    assert gt.poses.shape == (len(gt), 4, 4) and gt.poses.dtype == np.float64
    np.testing.assert_allclose(gt.poses[:, 3, :], np.tile([0, 0, 0, 1], (len(gt), 1)))
