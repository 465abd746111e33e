"""Fixtures of the Python tests. CTest (python/CMakeLists.txt) runs them with PYTHONPATH set to
the build tree's package and these variables: DESSLAM_BINARY (the `desslam` program),
DESSLAM_WRITE_SYNTHETIC (the tool that writes the synthetic scene), DESSLAM_SHARED_DIR (../shared
with the data clips), DESSLAM_SOURCE_DIR (the project)."""

import os
import pathlib
import subprocess

import pytest

SYNTHETIC_FRAMES = 60  # as tests/api/test_api.cpp


def _tool(variable):
    value = os.environ.get(variable)
    if not value or not pathlib.Path(value).exists():
        pytest.fail(f"{variable} is not set to a built program: run these tests through ctest "
                    f"(ctest --test-dir build -L python)")
    return value


@pytest.fixture(scope="session")
def desslam_binary():
    return _tool("DESSLAM_BINARY")


@pytest.fixture(scope="session")
def source_dir():
    return pathlib.Path(os.environ.get("DESSLAM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def synthetic(tmp_path_factory):
    """The synthetic static room: (sequence folder, its config.yaml)."""
    root = tmp_path_factory.mktemp("synthetic")
    subprocess.run([_tool("DESSLAM_WRITE_SYNTHETIC"), str(root), str(SYNTHETIC_FRAMES)], check=True)
    return root / "sequence", root / "config.yaml"


def run_program(binary, sequence, config, out, *extra):
    """`desslam run <sequence> -c <config> --deterministic --out <out>`; returns the output folder."""
    result = subprocess.run([binary, "run", str(sequence), "-c", str(config), "--deterministic", "--quiet",
                             "--out", str(out), *extra], capture_output=True, text=True)
    assert result.returncode == 0, f"desslam run failed ({result.returncode}): {result.stderr}"
    return out


@pytest.fixture(scope="session")
def synthetic_program_run(synthetic, desslam_binary, tmp_path_factory):
    """The program's deterministic run over the synthetic room (its output folder)."""
    sequence, config = synthetic
    return run_program(desslam_binary, sequence, config, tmp_path_factory.mktemp("program") / "out")


@pytest.fixture(scope="session")
def fr1_xyz_clip():
    shared = pathlib.Path(os.environ.get("DESSLAM_SHARED_DIR") or pathlib.Path(__file__).resolve().parents[3] / "shared")
    clip = shared / "data" / "clips" / "fr1_xyz_0000_0099"
    if not clip.exists():
        pytest.skip(f"shared data missing: {clip} (put ../shared beside the project, or set DESSLAM_SHARED_DIR)")
    return clip
