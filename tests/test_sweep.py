"""Sweeps: grid expansion, stable ids, bad files, resumability, failures, local pool vs Ray."""

from __future__ import annotations

import importlib
import json
import os
import shutil
import sys
from pathlib import Path

import pytest

from humanoid_ik.cli import main
from humanoid_ik.config.sweep_file import model_digest, model_files
from humanoid_ik.core.models import bundled_model_path
from humanoid_ik.errors import SweepError
from humanoid_ik.experiments.sweep import (
    TIMING_COLUMNS,
    Job,
    import_ray,
    load_sweep,
    parse_sweep,
    run_job,
    run_sweep,
)
from humanoid_ik.experiments.sweep.executors import PRELOAD

SCENES = Path(__file__).resolve().parents[1] / "scenes"

TINY = """
name = "tiny"
seeds = [0, 1]
solvers = ["closed_form", { name = "dls", grid = { restarts = [0, 5] } }]

[[scenes]]
scene = "compare_dls"
frames = 8

[[targets]]
name = "pose"
task = "pose"
n = 12
"""


def _write(tmp_path: Path, text: str, name: str = "sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _comparable(out: Path) -> list[dict]:
    rows = json.loads((out / "summary.json").read_text())["rows"]
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def test_grid_expansion_counts_and_stable_ids(tmp_path):
    """Sets x configurations x seeds; a scene without random motion runs once per config."""
    doc = {
        "seeds": [0, 1, 2],
        "solvers": [
            "closed_form",
            {"name": "dls", "grid": {"restarts": [0, 5], "damping": [0.05, 0.1]}},
        ],
        "scenes": [{"scene": "compare_dls", "frames": 5}, {"scene": "random_walk", "frames": 5}],
        "targets": [{"name": "a", "n": 3}, {"name": "b", "n": 3, "task": "position"}],
    }
    sweep = parse_sweep(doc, "grid.toml")
    configs = 1 + 2 * 2
    # compare_dls: 1 per config; random_walk and the two target sets: 3 seeds each
    assert len(sweep.jobs) == configs * (1 + 3 + 3 + 3)
    ids = [j.id for j in sweep.jobs]
    assert len(set(ids)) == len(ids)
    assert ids == [j.id for j in parse_sweep(doc, "grid.toml").jobs]
    assert all(len(i) == 12 and int(i, 16) >= 0 for i in ids)
    assert {j.seed for j in sweep.jobs if j.name == "compare_dls"} == {None}
    job = Job("targets", "a", "dls", {"restarts": 5}, 1, {"n": 3, "task": "pose"})
    assert job.id == Job("targets", "a", "dls", (("restarts", 5),), 1, {"task": "pose", "n": 3}).id
    assert job.id == "0a311afee700"  # the hash of the parameters, the same in every process
    assert job.config == "dls(restarts=5)"


def test_scene_seed_changes_random_walk_only(tmp_path):
    """Seeds reach the scene's random_walk motion: two seeds, two different paths."""
    doc = {
        "seeds": [0, 1],
        "solvers": ["closed_form"],
        "scenes": [{"scene": "random_walk", "frames": 6}],
    }
    sweep = parse_sweep(doc, "s.toml")
    res = run_sweep(sweep, tmp_path / "out", workers=1, plot=False)
    a, b = res.results
    assert a["status"] == b["status"] == "ok" and a["seed"] == 0 and b["seed"] == 1
    assert a["max_error_m"] != b["max_error_m"] or a["median_error_m"] != b["median_error_m"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("solvers = []\n[[targets]]\nname='a'\nn=1", "solvers: expected a non-empty list"),
        ("solvers = ['magic']\n[[targets]]\nname='a'\nn=1", "solvers[0].name: expected one of"),
        (
            "solvers = ['dls']\nseeds = [0, -1]\n[[targets]]\nname='a'\nn=1",
            "seeds[1]: expected an integer >= 0, got -1",
        ),
        (
            "solvers = ['dls']\nseeds = [2, 2]\n[[targets]]\nname='a'\nn=1",
            "seeds[1]: seed 2 given twice",
        ),
        (
            "solvers = ['dls']\n[[targets]]\nname='a'\nn=0",
            "targets[0].n: expected an integer >= 1 and <= 1000000, got 0",
        ),
        (
            "solvers = ['dls']\n[[targets]]\nname='a'\nn=2\ntask='walk'",
            "targets[0].task: expected one of 'position', 'pose', got 'walk'",
        ),
        (
            "solvers = ['dls']\n[[targets]]\nname='a'\nn=2\nsite='hand'",
            "targets[0].site: site 'hand' not in model",
        ),
        ("solvers = ['dls']\n[[targets]]\nname='a'\nn=2\nmodel='no.xml'", "targets[0].model:"),
        (
            "solvers = ['dls']\n[[targets]]\nname='a'\nn=2\njoints=[]",
            "targets[0].joints: expected a list of joint names",
        ),
        ("solvers = ['dls']\n[[targets]]\nname='a b'\nn=2", "targets[0].name: expected a name"),
        ("solvers = ['dls']\n[[targets]]\nn=2", "targets[0].name: missing"),
        (
            "solvers = ['dls']\n[[scenes]]\nscene='nowhere'",
            "scenes[0].scene: nowhere: no such scene file",
        ),
        ("solvers = ['dls']\n[[scenes]]\nscene=3", "scenes[0].scene: expected a bundled scene"),
        (
            "solvers = ['dls']\n[[scenes]]\nscene='circle'\nframes=0",
            "scenes[0].frames: expected an integer >= 1 and <= 100000, got 0",
        ),
        ("solvers = ['dls']\n[[scenes]]\nscene='circle'\nspeed=2", "scenes[0].speed: unknown key"),
        ("solvers = ['dls']", "scenes: no scenes and no targets"),
        ("solvers = ['dls']\nscenes = 'circle'", "scenes: expected a list of tables"),
        (
            "solvers = ['dls']\ncolour = 1\n[[targets]]\nname='a'\nn=1",
            "colour: unknown key; expected one of",
        ),
        ("seeds = [0]", "solvers: missing"),
        (
            "solvers = [{name='dls', grid={damping=0.1}}]\n[[targets]]\nname='a'\nn=1",
            "solvers[0].grid.damping: expected a non-empty list",
        ),
        (
            "solvers = [{name='dls', grid={damping=[-1]}}]\n[[targets]]\nname='a'\nn=1",
            "solvers[0].grid.damping: option 'damping'",
        ),
        (
            "solvers = [{name='dls', options={speed=1}}]\n[[targets]]\nname='a'\nn=1",
            "solvers[0].options: option 'speed' unknown",
        ),
        (
            "solvers = [{name='dls', options={damping=0.1}, grid={damping=[0.2]}}]\n"
            "[[targets]]\nname='a'\nn=1",
            "solvers[0].grid.damping: also given in options",
        ),
        (
            "solvers = [{name='dls', options=3}]\n[[targets]]\nname='a'\nn=1",
            "solvers[0].options: expected a table",
        ),
        (
            "solvers = [{name='dls', grid=3}]\n[[targets]]\nname='a'\nn=1",
            "solvers[0].grid: expected a table",
        ),
        ("solvers = [{options={}}]\n[[targets]]\nname='a'\nn=1", "solvers[0].name: missing"),
        ("solvers = ['dls', 'dls']\n[[targets]]\nname='a'\nn=1", "appears twice"),
        (
            "description = 3\nsolvers = ['dls']\n[[targets]]\nname='a'\nn=1",
            "description: expected a string",
        ),
        ("solvers = ['dls'\n", "not valid TOML"),
    ],
)
def test_bad_sweep_file_is_one_line(tmp_path, text, message):
    """Each mistake is one SweepError line naming the file, the key and the expectation."""
    path = _write(tmp_path, text, "bad.toml")
    with pytest.raises(SweepError) as err:
        load_sweep(path)
    text = str(err.value)
    assert "\n" not in text and "bad.toml: " in text and message in text, text


def test_missing_sweep_file():
    """A missing file is a SweepError naming it."""
    with pytest.raises(SweepError, match="no_such.toml: cannot be read"):
        load_sweep("no_such.toml")


def test_rerun_skips_finished_jobs(tmp_path):
    """A rerun executes nothing; a deleted result makes exactly that job run again."""
    sweep = load_sweep(_write(tmp_path, TINY))
    out = tmp_path / "out"
    first = run_sweep(sweep, out, workers=2)
    n = len(sweep.jobs)
    assert len(first.executed) == n and first.cached == []
    assert first.counts() == {"ok": n, "failed": 0, "skipped": 0}
    assert {p.name for p in first.files} == {
        "summary.csv",
        "summary.json",
        "summary.png",
        "run.json",
    }
    assert len(list((out / "jobs").glob("*.json"))) == n
    again = run_sweep(sweep, out, workers=2, plot=False)
    assert again.executed == [] and len(again.cached) == n
    gone = sweep.jobs[3]
    (out / "jobs" / f"{gone.id}.json").unlink()
    third = run_sweep(sweep, out, workers=2, plot=False)
    assert third.executed == [gone.id]
    assert _comparable(out) == [
        {k: v for k, v in r.items() if k not in TIMING_COLUMNS}
        for r in json.loads((out / "summary.json").read_text())["rows"]
    ]


def test_the_former_record_names_warn_and_give_the_new_objects(tmp_path):
    """A job's result was its "record": ``read_records``, ``damaged_records`` (package
    and ``resume``), ``failed_record``, ``new_record`` (``jobs``) and
    ``SweepResult.records`` stay for one release, each use with a ``DeprecationWarning``
    naming the new name and pointing at the line that used it, giving the new object."""
    import humanoid_ik.experiments.sweep as package
    from humanoid_ik.experiments.sweep import jobs, resume

    renamed = [
        (package, "read_records", "read_results"),
        (package, "damaged_records", "damaged_results"),
        (resume, "read_records", "read_results"),
        (resume, "damaged_records", "damaged_results"),
        (jobs, "failed_record", "failed_result"),
        (jobs, "new_record", "new_result"),
    ]
    for module, old, new in renamed:
        with pytest.warns(
            DeprecationWarning, match=rf"{old} is deprecated; use .*\.{new}$"
        ) as said:
            assert getattr(module, old) is getattr(module, new)
        assert said[0].filename == __file__
    with pytest.warns(DeprecationWarning, match="read_results"):
        from humanoid_ik.experiments.sweep import read_records
    job = load_sweep(_write(tmp_path, TINY)).jobs[0]
    assert read_records(tmp_path, [job]) == {}  # no jobs/ folder: nothing finished
    result = jobs.failed_result(job, RuntimeError("worker died"))
    assert result["id"] == job.id and result["error"] == "RuntimeError: worker died"
    done = resume.SweepResult([result], [job.id], [], [], 0.5)
    with pytest.warns(DeprecationWarning, match=r"SweepResult\.results") as said:
        assert done.records is done.results
    assert said[0].filename == __file__ and done.counts()["failed"] == 1
    with pytest.raises(AttributeError, match="no attribute 'read_jobs'"):
        package.read_jobs  # noqa: B018 - nothing else resolves


def test_failed_job_is_recorded_and_others_finish(tmp_path):
    """A job whose scene file changed after loading fails with its error; the rest finish."""
    scene = tmp_path / "mine.toml"
    scene.write_text((SCENES / "compare_dls.toml").read_text())
    text = TINY.replace('scene = "compare_dls"', 'scene = "mine.toml"')
    sweep = load_sweep(_write(tmp_path, text))
    scene.write_text(scene.read_text() + "\n# edited\n")
    res = run_sweep(sweep, tmp_path / "out", workers=2, plot=False)
    failed = [r for r in res.results if r["status"] == "failed"]
    assert len(failed) == 3 and all(r["kind"] == "scene" for r in failed)
    assert all("SweepError" in r["error"] and "changed" in r["error"] for r in failed)
    assert res.counts()["ok"] == len(sweep.jobs) - 3
    rows = json.loads((tmp_path / "out" / "summary.json").read_text())["rows"]
    assert sum(r["status"] == "failed" for r in rows) == 3
    again = run_sweep(sweep, tmp_path / "out", workers=1, plot=False)
    assert sorted(again.executed) == sorted(r["id"] for r in failed)


def test_skipped_solver_is_recorded(tmp_path):
    """A solver that does not fit the task (ccd on pose targets) is recorded as skipped."""
    doc = {"solvers": ["ccd"], "targets": [{"name": "p", "n": 2, "task": "pose"}]}
    res = run_sweep(parse_sweep(doc, "s.toml"), tmp_path, workers=1, plot=False)
    (result,) = res.results
    assert result["status"] == "skipped" and "position targets only" in result["error"]


def test_bad_workers_and_unwritable_out(tmp_path):
    """workers < 1 and an output path under a file are SweepErrors."""
    sweep = parse_sweep({"solvers": ["dls"], "targets": [{"name": "p", "n": 1}]}, "s.toml")
    with pytest.raises(SweepError, match="workers must be an integer >= 1 and <= 256, got 0"):
        run_sweep(sweep, tmp_path, workers=0)
    with pytest.raises(SweepError, match="workers must be an integer >= 1 and <= 256, got 257"):
        run_sweep(sweep, tmp_path, workers=257)
    (tmp_path / "file").write_text("")
    with pytest.raises(SweepError, match="cannot write"):
        run_sweep(sweep, tmp_path / "file" / "out")
    with pytest.raises(SweepError, match="expected one of scene, targets"):
        Job("movie", "x", "dls")


def test_ray_missing_names_the_extra(monkeypatch):
    """Without Ray the error says how to install the extra."""
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(SweepError, match=r"pip install 'humanoid-ik\[ray\]'"):
        import_ray()


def test_forkserver_preload_names_the_job_modules():
    """The local pool preloads modules that exist, among them the one run_job lives in."""
    for name in PRELOAD:
        importlib.import_module(name)
    assert run_job.__module__ in PRELOAD


@pytest.mark.slow
def test_local_pool_and_ray_give_the_same_summary(tmp_path):
    """The summary's non-timing columns are the same on the local pool and on Ray."""
    ray = pytest.importorskip("ray")
    sweep = load_sweep(_write(tmp_path, TINY))
    local = run_sweep(sweep, tmp_path / "local", workers=2, plot=False)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        remote = run_sweep(sweep, tmp_path / "ray", ray_address="local", plot=False)
    finally:
        ray.shutdown()
    assert len(local.executed) == len(remote.executed) == len(sweep.jobs)
    assert _comparable(tmp_path / "local") == _comparable(tmp_path / "ray")
    csv_local = (tmp_path / "local" / "summary.csv").read_text().splitlines()
    assert len(csv_local) == len(sweep.jobs) + 1


@pytest.mark.slow
def test_local_ray_runs_in_a_process_group_of_its_own_and_tags_nothing(tmp_path):
    """``--ray local`` (no Ray initialised here) runs Ray from a process of its own, in
    a process group that is not the caller's, and puts nothing into the caller's
    environment, not even while the results come back; the summary equals the local
    pool's."""
    ray = pytest.importorskip("ray")
    sweep = load_sweep(_write(tmp_path, TINY.replace("seeds = [0, 1]", "seeds = [0]")))
    local = run_sweep(sweep, tmp_path / "local", workers=2, plot=False)
    before = dict(os.environ)
    seen: list[tuple[dict[str, str], int]] = []

    def on_result(done, total, result):
        seen.append((dict(os.environ), os.getpgrp()))

    assert not ray.is_initialized()
    remote = run_sweep(
        sweep, tmp_path / "ray", workers=2, ray_address="local", progress=on_result, plot=False
    )
    assert not ray.is_initialized() and dict(os.environ) == before
    assert seen == [(before, os.getpgrp())] * len(sweep.jobs)
    assert len(local.executed) == len(remote.executed) == len(sweep.jobs)
    assert _comparable(tmp_path / "local") == _comparable(tmp_path / "ray")


def test_cli_sweep_runs_and_errors_are_one_line(tmp_path, capsys):
    """The sweep command writes the summary (exit 0); a bad file is one line, exit 2."""
    path = _write(tmp_path, TINY.replace("seeds = [0, 1]", "seeds = [0]"))
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "1", "--no-plot"]) == 0
    text = capsys.readouterr().out
    assert "sweep tiny: 6 job(s), 0 already done" in text and "wrote" in text
    assert (out / "summary.csv").is_file() and not (out / "summary.png").exists()
    bad = _write(tmp_path, "solvers = ['magic']\n[[targets]]\nname='a'\nn=1", "bad.toml")
    assert main(["sweep", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.toml: solvers[0].name: expected one of" in err
    assert main(["sweep", str(path), "--workers", "0"]) == 2
    assert "--workers: expected an integer >= 1" in capsys.readouterr().err
    assert main(["sweep", str(path), "--out", str(path)]) == 2
    assert "is a file" in capsys.readouterr().err


def test_broken_scene_job_still_gets_summary_and_plot(tmp_path):
    """A scene file broken after loading fails its job; the summary and plot are written."""
    scene = tmp_path / "mine.toml"
    scene.write_text((SCENES / "compare_dls.toml").read_text())
    doc = {"solvers": ["closed_form"], "scenes": [{"scene": str(scene), "frames": 3}]}
    sweep = parse_sweep(doc, "s.toml")
    scene.write_text("broken = ")
    res = run_sweep(sweep, tmp_path / "out", workers=1)
    (result,) = res.results
    assert result["status"] == "failed" and "SceneError" in result["error"]
    assert (tmp_path / "out" / "summary.png").is_file()


MODELS = """
name = "models"
solvers = ["closed_form"]

[[scenes]]
scene = "mine.toml"
frames = 3

[[targets]]
name = "mine"
n = 3
model = "model/scene.xml"

[[targets]]
name = "bundled"
n = 3
"""


def _own_model(tmp_path: Path) -> Path:
    """A copy of the bundled humanoid (``scene.xml`` including ``humanoid.xml``) and a
    scene and a sweep using it; returns the sweep file."""
    shutil.copytree(bundled_model_path().parent, tmp_path / "model")
    scene = (SCENES / "compare_dls.toml").read_text()
    (tmp_path / "mine.toml").write_text('model = "model/scene.xml"\n' + scene)
    return _write(tmp_path, MODELS)


def test_edited_model_file_runs_its_jobs_again(tmp_path):
    """Job ids hold the SHA-256 of the model and every file it includes: editing the
    included humanoid.xml of a copied model reruns exactly the scene and target set that
    use it (not the one on the bundled model), with the new model's numbers."""
    path = _own_model(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(load_sweep(path), out, workers=1, plot=False)
    assert len(first.executed) == 3 and first.counts()["ok"] == 3
    assert run_sweep(load_sweep(path), out, workers=1, plot=False).executed == []
    included = tmp_path / "model" / "humanoid.xml"
    text = included.read_text()
    old = 'name="right_shoulder_flexion_joint" axis="0 -1 0" range="-1.05 3.14"'
    assert old in text
    included.write_text(text.replace(old, old.replace("-1.05 3.14", "-0.2 0.2")))
    sweep = load_sweep(path)
    mine = sorted(j.id for j in sweep.jobs if j.name in ("mine", "compare_dls"))
    again = run_sweep(sweep, out, workers=1, plot=False)
    assert sorted(again.executed) == mine and len(again.cached) == 1
    before = {r["name"]: r for r in first.results}
    after = {r["name"]: r for r in again.results}
    assert after["bundled"] == before["bundled"]
    assert after["mine"]["id"] != before["mine"]["id"]
    assert after["mine"]["max_error_m"] != before["mine"]["max_error_m"]


def test_model_changed_after_loading_fails_its_jobs(tmp_path):
    """A model edited between loading the sweep and running a job fails that job, naming
    the model; the job on the bundled model still runs."""
    path = _own_model(tmp_path)
    sweep = load_sweep(path)
    (tmp_path / "model" / "humanoid.xml").write_text(
        (tmp_path / "model" / "humanoid.xml").read_text() + "\n<!-- edited -->\n"
    )
    res = run_sweep(sweep, tmp_path / "out", workers=1, plot=False)
    failed = {r["name"]: r["error"] for r in res.results if r["status"] == "failed"}
    assert sorted(failed) == ["compare_dls", "mine"]
    assert all(
        "scene.xml" in e and "changed after the sweep was loaded" in e for e in failed.values()
    )
    assert res.counts()["ok"] == 1


def test_model_files_follow_includes_and_assets(tmp_path):
    """The files of a model: includes (nested, from the main file's folder or the
    including file's), and asset files under the compiler's meshdir and texturedir."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "meshes").mkdir()
    (tmp_path / "main.xml").write_text(
        '<mujoco><compiler meshdir="meshes" texturedir="tex"/><include file="sub/a.xml"/>'
        '<asset><mesh file="arm.stl"/><texture name="t" type="2d" file="skin.png"/>'
        '<mesh name="gone" file="missing.stl"/></asset></mujoco>'
    )
    (tmp_path / "sub" / "a.xml").write_text('<mujoco><include file="b.xml"/></mujoco>')
    (tmp_path / "sub" / "b.xml").write_text("<mujoco/>")
    (tmp_path / "meshes" / "arm.stl").write_bytes(b"solid")
    (tmp_path / "tex").mkdir()
    (tmp_path / "tex" / "skin.png").write_bytes(b"png")
    files = [p.relative_to(tmp_path).as_posix() for p in model_files(tmp_path / "main.xml")]
    assert files == ["main.xml", "sub/a.xml", "sub/b.xml", "meshes/arm.stl", "tex/skin.png"]
    digest = model_digest(tmp_path / "main.xml")
    for f in files:
        before = (tmp_path / f).read_bytes()
        (tmp_path / f).write_bytes(before + b" ")
        assert model_digest(tmp_path / "main.xml") != digest, f
        (tmp_path / f).write_bytes(before)
    assert model_digest(tmp_path / "main.xml") == digest
    moved = tmp_path / "moved"
    shutil.copytree(tmp_path, moved, ignore=shutil.ignore_patterns("moved"))
    assert model_digest(moved / "main.xml") == digest  # contents, not where the tree is
