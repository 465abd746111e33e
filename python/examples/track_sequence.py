"""Tracks a TUM-layout sequence folder from Python and prints the ATE/RPE against its ground truth.

    PYTHONPATH=build/python python3 python/examples/track_sequence.py <sequence-dir> config/tum_fr1.yaml
"""
import sys

import desslam

sequence_dir, config_file = sys.argv[1], sys.argv[2]
config = desslam.Config.from_yaml(config_file).set("dense.enabled=false")
dataset = desslam.TumDataset(sequence_dir)
with desslam.Slam(config, deterministic=True) as slam:
    for i in range(len(dataset)):
        frame = dataset.load(i, config)  # bgr: HxWx3 uint8, depth: HxW float32 metres
        result = slam.track(frame.timestamp, frame.bgr, frame.depth, frame.depth_time_offset, frame.image_name)
        if result.has_pose and i % 30 == 0:
            print(f"{frame.timestamp:.3f}  map {result.map_id}  position {result.T_w_c[:3, 3].round(3)}")
trajectory = slam.trajectory()  # after finish(): timestamps (N,), poses (N,4,4), map ids
desslam.write_tum_trajectory("CameraTrajectory.txt", trajectory)
print(f"{len(trajectory)} of {len(dataset)} frames in the main map")
if dataset.ground_truth is not None:
    print(desslam.evaluate(dataset.ground_truth, trajectory).table())
