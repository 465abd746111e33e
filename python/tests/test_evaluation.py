"""ATE/RPE from Python: the figures `desslam eval` prints, on files and on arrays, and known
answers on trajectories made with numpy."""

import json
import subprocess

import numpy as np
import pytest

import desslam


def program_eval(binary, gt, est, *extra):
    result = subprocess.run([binary, "eval", str(gt), str(est), *extra], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result.stdout


def figures(evaluation):
    """The numbers of an Evaluation, by attribute (not through its JSON)."""
    a, r = evaluation.ate, evaluation.rpe
    return {
        "ate": [a.translation_m.rmse, a.translation_m.mean, a.translation_m.median, a.translation_m.std,
                a.translation_m.min, a.translation_m.max, a.translation_m.count, a.matched, a.gt_poses, a.est_poses],
        "rpe": [r.translation_m.rmse, r.translation_m.mean, r.translation_m.median, r.translation_m.max,
                r.rotation_deg.rmse, r.rotation_deg.mean, r.rotation_deg.median, r.rotation_deg.max, r.pairs,
                r.delta_s],
    }


def json_figures(report):
    a, r = report["ate"], report["rpe"]
    at, rt, rr = a["translation_m"], r["translation_m"], r["rotation_deg"]
    return {
        "ate": [at["rmse"], at["mean"], at["median"], at["std"], at["min"], at["max"], at["count"], a["matched"],
                a["gt_poses"], a["est_poses"]],
        "rpe": [rt["rmse"], rt["mean"], rt["median"], rt["max"], rr["rmse"], rr["mean"], rr["median"], rr["max"],
                r["pairs"], r["delta_s"]],
    }


@pytest.mark.parametrize("max_dt, delta_s", [(0.02, 1.0), (0.01, 0.5)])
def test_files_give_the_figures_of_desslam_eval(synthetic, synthetic_program_run, desslam_binary, max_dt, delta_s):
    sequence, _ = synthetic
    gt, est = sequence / "groundtruth.txt", synthetic_program_run / "CameraTrajectory.txt"
    options = ["--max-dt", str(max_dt), "--delta", str(delta_s)]
    report = json.loads(program_eval(desslam_binary, gt, est, "--json", *options))
    evaluation = desslam.evaluate(gt, est, max_dt=max_dt, delta_s=delta_s)
    assert figures(evaluation) == json_figures(report)  # the same code: equal to the last bit
    as_dict = evaluation.to_dict()
    # T_gt_est is kept as a 4x4 matrix; its quaternion, recomputed from it, agrees to rounding.
    alignment, program_alignment = as_dict["ate"].pop("T_gt_est"), report["ate"].pop("T_gt_est")
    assert as_dict == {"ate": report["ate"], "rpe": report["rpe"]}
    assert alignment["translation"] == program_alignment["translation"]
    np.testing.assert_allclose(alignment["quaternion_xyzw"], program_alignment["quaternion_xyzw"], atol=1e-14)
    np.testing.assert_array_equal(evaluation.ate.T_gt_est[:3, 3], program_alignment["translation"])
    assert evaluation.table() == program_eval(desslam_binary, gt, est, *options)
    assert evaluation.ate.matched >= 0.95 * len(desslam.read_tum_trajectory(est))
    assert 0 < evaluation.ate.translation_m.rmse < 0.01  # the synthetic room is tracked within 1 cm


def test_arrays_give_the_same_figures(synthetic, synthetic_program_run, desslam_binary):
    sequence, _ = synthetic
    gt_file, est_file = sequence / "groundtruth.txt", synthetic_program_run / "CameraTrajectory.txt"
    report = json.loads(program_eval(desslam_binary, gt_file, est_file, "--json"))
    gt, est = desslam.read_tum_trajectory(gt_file), desslam.read_tum_trajectory(est_file)
    # Fresh arrays (not the reader's objects): numpy in, the same figures out. The 4x4 matrices
    # are turned back into quaternions, so equal to rounding (1e-12), not to the bit.
    arrays = desslam.evaluate(desslam.Trajectory(gt.timestamps.copy(), gt.poses.copy()),
                              (est.timestamps.tolist(), est.poses.astype(np.float64)))
    expected = json_figures(report)
    for key in ("ate", "rpe"):
        np.testing.assert_allclose(figures(arrays)[key], expected[key], rtol=1e-12, atol=1e-15)
    ate, rpe = desslam.ate(gt, est), desslam.rpe(gt, est)
    assert ate.translation_m.rmse == pytest.approx(arrays.ate.translation_m.rmse, rel=1e-12)
    assert rpe.rotation_deg.rmse == pytest.approx(arrays.rpe.rotation_deg.rmse, rel=1e-12)


def make_trajectory(n=90, rate_hz=30.0):
    """A camera moving along a helix while turning (numpy only)."""
    t = 1000.0 + np.arange(n) / rate_hz
    poses = np.tile(np.eye(4), (n, 1, 1))
    for i, s in enumerate(t - t[0]):
        a, b = 0.8 * s, 0.3 * np.sin(2 * s)
        rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
        poses[i, :3, :3] = rz @ rx
        poses[i, :3, 3] = [np.cos(s), np.sin(s), 0.2 * s]
    return t, poses


def rigid(angle, axis, translation):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    T = np.eye(4)
    T[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    T[:3, 3] = translation
    return T


def test_known_answers_on_arrays():
    t, gt_poses = make_trajectory()
    gt = desslam.Trajectory(t, gt_poses)
    # The same motion seen in another world frame: no error, and the alignment undoes the change.
    A = rigid(0.7, [1, 2, 3], [0.5, -2.0, 1.0])
    est = desslam.Trajectory(t + 0.004, A @ gt_poses)  # stamps 4 ms off: within max_dt
    e = desslam.evaluate(gt, est)
    assert e.ate.matched == len(t)
    assert e.ate.translation_m.rmse < 1e-9 and e.rpe.translation_m.rmse < 1e-9 and e.rpe.rotation_deg.rmse < 1e-6
    np.testing.assert_allclose(e.ate.T_gt_est, np.linalg.inv(A), atol=1e-9)
    assert e.rpe.pairs > 0 and e.rpe.delta_s == 1.0
    # Every estimate position 3 cm off along its own camera x axis, rotations exact: the RPE
    # rotation stays zero, the ATE and RPE translation do not.
    shifted = gt_poses.copy()
    shifted[:, :3, 3] += 0.03 * gt_poses[:, :3, 0]
    e = desslam.evaluate(gt, (t, shifted))
    assert 0.001 < e.ate.translation_m.rmse <= 0.03 + 1e-9
    assert e.rpe.rotation_deg.rmse < 1e-6 and e.rpe.translation_m.rmse > 0.001
    # Stamps far apart do not associate.
    with pytest.raises(RuntimeError, match="max_dt"):
        desslam.ate(gt, desslam.Trajectory(t + 10.0, gt_poses))


def test_tum_files_round_trip(tmp_path):
    t, poses = make_trajectory(30)
    desslam.write_tum_trajectory(tmp_path / "trajectory.txt", desslam.Trajectory(t, poses))
    back = desslam.read_tum_trajectory(tmp_path / "trajectory.txt")
    np.testing.assert_allclose(back.timestamps, t, rtol=0, atol=5e-7)  # six decimals
    np.testing.assert_allclose(back.poses, poses, rtol=0, atol=1e-8)  # nine decimals
    assert back.positions.shape == (30, 3)
    np.testing.assert_array_equal(back.positions, back.poses[:, :3, 3])
