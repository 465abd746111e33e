"""DeS-SLAM: RGB-D SLAM for dynamic scenes, from Python.

    import desslam
    config = desslam.Config.from_yaml("config/tum_fr1.yaml").set("dense.enabled=false")
    dataset = desslam.TumDataset("data/fr1_xyz")
    with desslam.Slam(config, deterministic=True) as slam:
        for i in range(len(dataset)):
            f = dataset.load(i, config)
            r = slam.track(f.timestamp, f.bgr, f.depth, f.depth_time_offset, f.image_name)
    print(desslam.evaluate(dataset.ground_truth, slam.trajectory()).table())

Images are numpy arrays: colour HxWx3 uint8 in BGR order (track(..., rgb=True) for RGB), depth
HxW float32 metres or uint16 raw units (divided by camera.depth_factor). Poses are 4x4 float64
world-from-camera matrices. Errors from the C++ library are RuntimeError naming the file, option
or input at fault; arrays of the wrong dtype raise TypeError, of the wrong shape ValueError.
"""

from ._desslam import (  # noqa: F401  (the extension built from python/src/desslam_python.cpp)
    AteFigures,
    Config,
    ErrorSummary,
    Evaluation,
    RgbdFrame,
    RpeFigures,
    Slam,
    TrackingState,
    TrackResult,
    Trajectory,
    TumDataset,
    ate,
    evaluate,
    read_tum_trajectory,
    rpe,
    version,
    write_tum_trajectory,
)

__version__ = version()
