"""Datasets: reproducible content, chunk independence, FK of solutions = targets, errors."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from humanoid_ik import Chain
from humanoid_ik.cli import main
from humanoid_ik.core.rotations import quat_to_mat
from humanoid_ik.errors import DatasetError, SolverError
from humanoid_ik.experiments.dataset import BLOCK, FORMAT, read_dataset, write_dataset


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_same_seed_same_file_whatever_the_chunks(tmp_path):
    """Same seed and n give byte-identical files for chunk sizes 1000, 4096 and 9000."""
    n = BLOCK + 1500
    paths = []
    for chunk in (1000, BLOCK, 9000):
        paths.append(write_dataset(tmp_path / f"c{chunk}.npz", n, 5, chunk=chunk))
    assert len({_sha(p) for p in paths}) == 1
    a, b = read_dataset(paths[0]), read_dataset(paths[2])
    for k in ("positions", "quats", "q", "ok"):
        assert np.array_equal(getattr(a, k), getattr(b, k))


def test_different_seed_differs_and_smaller_n_is_a_prefix(tmp_path):
    """Another seed gives other targets; a smaller n gives the first rows of a larger one."""
    big = read_dataset(write_dataset(tmp_path / "big.npz", 300, 1, chunk=64))
    small = read_dataset(write_dataset(tmp_path / "small.npz", 70, 1, chunk=7))
    other = read_dataset(write_dataset(tmp_path / "other.npz", 70, 2))
    assert np.array_equal(small.q, big.q[:70])
    assert np.array_equal(small.positions, big.positions[:70])
    assert not np.allclose(other.positions, small.positions)


def test_fk_of_every_solution_is_its_target(tmp_path):
    """MuJoCo FK of each stored joint vector equals the stored pose to 1e-9, inside ranges."""
    data = read_dataset(write_dataset(tmp_path / "d.npz", 600, 11, chunk=250))
    chain = Chain()
    assert data.q.shape == (600, 7) and data.positions.shape == (600, 3)
    assert data.quats.shape == (600, 4) and data.ok.all()
    assert np.allclose(np.linalg.norm(data.quats, axis=1), 1.0, atol=1e-12)
    assert (data.quats[:, 0] >= 0).all()
    for q, p, quat in zip(data.q, data.positions, data.quats, strict=True):
        assert chain.within_limits(q)
        p_fk, R_fk = chain.fk(q)
        assert np.abs(p_fk - p).max() < 1e-9
        assert np.abs(R_fk - quat_to_mat(quat)).max() < 1e-9


def test_metadata_names_model_site_joints_and_seed(tmp_path):
    """The file's metadata holds the format, model, site, joint names, seed and n."""
    path = write_dataset(tmp_path / "m.npz", 5, 9, site="left_palm_site")
    meta = read_dataset(path).meta
    assert meta["format"] == FORMAT and meta["model"] == "models/humanoid/scene.xml"
    assert meta["site"] == "left_palm_site" and meta["seed"] == 9 and meta["n"] == 5
    assert meta["joints"] == list(Chain(site="left_palm_site").joint_names)
    assert meta["solver"] == "closed_form"
    with np.load(path) as npz:  # a plain .npz: numpy opens it without the helper
        assert set(npz.files) == {"positions", "quats", "q", "ok", "meta"}


@pytest.mark.parametrize(
    ("where", "kind", "name"),
    [
        (["--body", "right_hand_link"], "body", "right_hand_link"),
        (["--arm", "left"], "site", "left_palm_site"),
    ],
)
def test_the_command_lines_end_effector_is_the_datasets(tmp_path, capsys, where, kind, name):
    """``dataset --body`` and ``--arm`` make the pairs of the chain they name (FK of each
    solution of that end effector is its target), and the metadata says which."""
    out = tmp_path / "d.npz"
    assert main(["dataset", "--n", "40", "--out", str(out), *where]) == 0
    capsys.readouterr()
    data = read_dataset(out)
    chain = Chain(**{kind: name})
    assert data.meta[kind] == name and data.meta["joints"] == list(chain.joint_names)
    assert "site" not in data.meta if kind == "body" else "body" not in data.meta
    for q, p in zip(data.q, data.positions, strict=True):
        assert np.abs(chain.fk(q)[0] - p).max() < 1e-9


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n": 0}, "n must be an integer >= 1 and <= 100000000, got 0"),
        ({"n": 10**14}, "n must be an integer >= 1 and <= 100000000, got 100000000000000"),
        ({"n": 5, "seed": -1}, "seed must be an integer >= 0, got -1"),
        ({"n": 5, "chunk": 0}, "chunk must be an integer >= 1 and <= 1048576, got 0"),
        ({"n": 5, "chunk": 10**7}, "chunk must be an integer >= 1 and <= 1048576, got 10000000"),
        (
            {"n": 5, "site": "gaze_site", "solver": "closed_form"},
            "closed_form does not fit chain gaze_site: closed_form needs 7 hinges",
        ),
    ],
)
def test_bad_requests_raise(tmp_path, kwargs, message):
    """Bad sizes, seeds and chains raise DatasetError naming the value."""
    with pytest.raises(DatasetError, match=message):
        write_dataset(tmp_path / "x.npz", **kwargs)


def test_missing_folder_and_bad_files(tmp_path):
    """An output folder that does not exist and files that are no dataset raise."""
    with pytest.raises(SolverError, match="solver 'nope' unknown; solvers: auto, ccd"):
        write_dataset(tmp_path / "x.npz", 5, solver="nope")
    with pytest.raises(DatasetError, match="does not exist"):
        write_dataset(tmp_path / "nope" / "x.npz", 3)
    with pytest.raises(DatasetError, match="cannot read dataset"):
        read_dataset(tmp_path / "absent.npz")
    np.savez(tmp_path / "plain.npz", a=np.zeros(2))
    with pytest.raises(DatasetError, match="not a humanoid_ik dataset: no positions"):
        read_dataset(tmp_path / "plain.npz")
    arrays = {k: np.zeros(1) for k in ("positions", "quats", "q", "ok")}
    np.savez(tmp_path / "old.npz", meta=np.array('{"format": "old"}'), **arrays)
    with pytest.raises(DatasetError, match="has format 'old'"):
        read_dataset(tmp_path / "old.npz")


def test_cli_dataset_and_its_errors(tmp_path, capsys):
    """dataset writes the file and reports pairs/s; bad input is one line and exit 2."""
    out = tmp_path / "d.npz"
    assert main(["dataset", "--n", "50", "--out", str(out), "--seed", "3", "--chunk", "20"]) == 0
    assert "50 pairs (seed 3)" in capsys.readouterr().out
    assert read_dataset(out).meta["seed"] == 3
    for argv, message in (
        (["--n", "0", "--out", str(out)], "--n: expected an integer >= 1, got '0'"),
        (["--n", "5", "--out", str(tmp_path / "d.csv")], "must end in .npz"),
        (["--n", "5", "--out", str(out), "--seed", "-2"], "--seed: expected an integer >= 0"),
        (
            ["--n", "5", "--out", str(out), "--site", "gaze_site", "--solver", "closed_form"],
            "closed_form does not fit",
        ),
        (
            ["--n", "5", "--out", str(out), "--solver", "nope"],
            "solver 'nope' unknown; solvers: auto",
        ),
        (["--n", "5", "--out", str(out), "--site", "hand"], "site 'hand' not in model"),
    ):
        assert main(["dataset", *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err


def test_dataset_on_a_real_arm_that_closed_form_does_not_fit(tmp_path):
    """G1's left arm with its waist (10 hinges: no closed form) gets ``auto``'s answers:
    every stored solution's FK is its target's pose within the solvers' default
    tolerances (0.1 mm, 1e-3 rad), inside the ranges; the same seed gives the same
    bytes, and the rows equal one-call solves from home."""
    from humanoid_ik import Chain, Target, load_model, solve
    from humanoid_ik.core.rotations import mat_to_quat
    from tests.robots import robot_file

    chain = Chain(load_model(robot_file("g1")), body="left_rubber_hand")
    assert chain.n == 10
    paths = [tmp_path / f"g1_{i}.npz" for i in range(2)]
    for path, chunk in zip(paths, (300, 7), strict=True):
        write_dataset(path, 300, seed=4, chunk=chunk, chain=chain, model=robot_file("g1"))
    assert _sha(paths[0]) == _sha(paths[1])
    data = read_dataset(paths[0])
    assert data.meta["solver"] == "auto" and data.meta["format"] == FORMAT
    assert data.q.shape == (300, 10) and data.ok.all()
    for i in range(300):
        p, R = chain.fk(data.q[i])
        assert np.linalg.norm(p - data.positions[i]) < 1e-4, i
        angle = 2 * np.arccos(min(1.0, abs(float(mat_to_quat(R) @ data.quats[i]))))
        assert angle < 1e-3, i
        assert np.all(data.q[i] >= chain.lower - 1e-12) and np.all(data.q[i] <= chain.upper + 1e-12)
    for i in (0, 137, 299):
        r = solve(chain, Target(data.positions[i], data.quats[i]), "auto", q0=chain.q_home)
        np.testing.assert_array_equal(r.q, data.q[i])


def test_format_1_files_still_read(tmp_path):
    """A format-1 dataset (member ``closed_form_ok``) reads with ``ok``."""
    arrays = {"positions": np.zeros((2, 3)), "quats": np.zeros((2, 4)), "q": np.zeros((2, 7))}
    meta = np.array('{"format": "humanoid_ik.dataset/1"}')
    path = tmp_path / "v1.npz"
    np.savez(path, meta=meta, closed_form_ok=np.array([True, False]), **arrays)
    data = read_dataset(path)
    assert data.ok.tolist() == [True, False]
    with pytest.warns(DeprecationWarning, match="Dataset.ok"):
        assert data.closed_form_ok.tolist() == [True, False]
