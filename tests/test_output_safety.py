"""What the tool writes lands where ``--out`` says and nowhere else: a device, a FIFO or
a socket given as an output is refused in one line and left as it was; a symbolic link
is written through (the link kept, its file replaced)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import uuid

import pytest

from humanoid_ik.cli import main
from humanoid_ik.experiments.dataset import read_dataset
from humanoid_ik.outputs.atomic import MANIFEST, write_text
from tests.chains import PLANAR_ARM_XML
from tests.processes import ended, signal_when, start, temporaries

COMMANDS = {
    "dataset": ["dataset", "--n", "5", "--out", "{out}"],
    "bench": ["bench", "--solver", "closed_form", "--n", "5", "--json", "{out}"],
    "inspect": ["inspect", "--save-limbs", "{out}"],
}
"""Commands that write one file, with ``{out}`` where it goes."""


def _args(command: str, out: os.PathLike) -> list[str]:
    return [str(out) if a == "{out}" else a for a in COMMANDS[command]]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_output_onto_a_fifo_is_refused_and_the_fifo_kept(tmp_path, capsys, command):
    fifo = tmp_path / "pipe.npz"
    os.mkfifo(fifo)
    assert main(_args(command, fifo)) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "not a regular file" in err and str(fifo) in err, err
    assert fifo.is_fifo() and sorted(p.name for p in tmp_path.iterdir()) == ["pipe.npz"]


def test_a_socket_is_never_replaced_from_python(tmp_path):
    """The Python writers refuse a non-regular file too (a socket here: a device such as
    ``/dev/null`` is refused by the same rule, but a test must not risk replacing one)."""
    path = tmp_path / "s.json"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        with pytest.raises(OSError, match="not a regular file"):
            write_text(path, "x")
        assert path.is_socket()


def test_an_output_through_a_symbolic_link_replaces_its_file_and_keeps_the_link(tmp_path, capsys):
    real = tmp_path / "real"
    real.mkdir()
    (real / "d.npz").write_text("old")
    link = tmp_path / "d.npz"
    link.symlink_to(real / "d.npz")
    assert main(["dataset", "--n", "5", "--out", str(link)]) == 0
    capsys.readouterr()
    assert link.is_symlink() and read_dataset(real / "d.npz").positions.shape == (5, 3)
    bench = tmp_path / "b.json"
    bench.symlink_to(real / "b.json")  # a dangling link: its file is made
    assert main(["bench", "--solver", "closed_form", "--n", "5", "--json", str(bench)]) == 0
    capsys.readouterr()
    assert bench.is_symlink() and json.loads((real / "b.json").read_text())


UNLIMITED_ARM = PLANAR_ARM_XML.replace("RANGE", 'range="-2 2"')
"""A planar arm whose shoulder is continuous (no range): its range margin is infinite."""


def _strict(text: str):
    def refuse(name: str):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_machine_readable_outputs_are_strict_json_with_a_continuous_joint(tmp_path, capsys):
    """``solve --json``, ``inspect --json`` and ``bench --json`` on an arm with a
    continuous joint parse with a strict parser: the unlimited margin is ``null``."""
    model = tmp_path / "arm.xml"
    model.write_text(UNLIMITED_ARM)
    where = ["--model", str(model), "--site", "tip"]
    assert main(["solve", *where, "--target", "0.3,0.2,0", "--json"]) == 0
    solved = _strict(capsys.readouterr().out)
    assert solved["status"] == "converged"
    assert main(["inspect", "--model", str(model), "--json"]) == 0
    _strict(capsys.readouterr().out)
    out = tmp_path / "bench.json"
    assert main(["bench", *where, "--solver", "dls", "--n", "5", "--json", str(out)]) == 0
    capsys.readouterr()
    _strict(out.read_text())
    assert _strict(write_text(tmp_path / "x.json", "{}").read_text()) == {}


def test_json_text_writes_non_finite_numbers_as_null():
    from humanoid_ik.outputs.atomic import json_text

    doc = {"margin": float("inf"), "nan": [float("nan"), 1.5], "q": (-float("inf"),)}
    assert _strict(json_text(doc)) == {"margin": None, "nan": [None, 1.5], "q": [None]}


def test_a_run_never_writes_over_the_users_own_files(tmp_path, capsys):
    """A folder holding the user's ``metrics.csv`` (no earlier run published it): ``run``
    refuses in one line naming it, writes nothing, and leaves it as it was; files of an
    earlier run there are replaced as usual."""
    out = tmp_path / "mine"
    out.mkdir()
    (out / "metrics.csv").write_text("my numbers\n")
    assert main(["run", "circle", "--frames", "3", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no earlier run wrote" in err, err
    assert str(out / "metrics.csv") in err
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["metrics.csv"]
    assert (out / "metrics.csv").read_text() == "my numbers\n"
    (out / "metrics.csv").unlink()
    assert main(["run", "circle", "--frames", "3", "--out", str(out)]) == 0
    assert main(["run", "circle", "--frames", "4", "--out", str(out)]) == 0  # its own set
    capsys.readouterr()
    assert len((out / "trajectory.csv").read_text().splitlines()) == 1 + 1 + 4


def test_a_replay_into_its_own_folder_keeps_its_input(tmp_path, capsys):
    """``replay DIR/trajectory.npz --out DIR`` would replace the render's set it comes
    from (the input included): refused in one line, the input kept."""
    out = tmp_path / "run"
    assert main(["run", "circle", "--frames", "3", "--out", str(out)]) == 0
    before = (out / "trajectory.npz").read_bytes()
    capsys.readouterr()
    assert main(["replay", str(out / "trajectory.npz"), "--out", str(out), "--no-video"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "choose another --out" in err, err
    assert (out / "trajectory.npz").read_bytes() == before


@pytest.mark.slow
@pytest.mark.parametrize("command", ["render", "run"])
def test_ctrl_c_before_the_first_frame_keeps_the_previous_set(tmp_path, capsys, command):
    """SIGINT as a re-run starts (its staging folder just made; a render's film is
    starting): the folder then holds either the previous set, whole, or the new run's
    with at least one frame, never a set of 0 frames in place of the previous one."""
    out = tmp_path / "out"
    assert main(["run", "circle", "--frames", "3", "--out", str(out)]) == 0
    capsys.readouterr()
    tag = uuid.uuid4().hex
    args = [command, "circle", "--out", str(out), "--frames", "30"]
    proc = start(
        [*args, *(["--width", "64", "--height", "48"] if command == "render" else [])], tag
    )
    staging = lambda: any(p.name.startswith(".run.") for p in out.iterdir())  # noqa: E731
    sent = signal_when(proc, signal.SIGINT, staging, poll=0.0005)
    _o, err = ended(proc, tag, 120)
    assert proc.returncode in ((130, 0) if sent else (0,)), err.decode()
    names = json.loads((out / MANIFEST).read_text())["files"]
    assert all((out / n).is_file() for n in names), names
    rows = (out / "trajectory.csv").read_text().splitlines()[2:]
    assert len(rows) >= 1 and ("trajectory.csv" in names)
    assert temporaries(out) == []


NAN_ARM = UNLIMITED_ARM.replace(
    '<body name="fore" pos="0.3 0 0">', '<body name="fore" pos="nan 0 0">'
)
"""The planar arm with a NaN in its forearm's position."""


@pytest.mark.parametrize("command", ["solve", "inspect", "bench"])
def test_a_model_with_nan_is_refused_in_one_line_and_writes_no_log(tmp_path, command):
    """``pos="nan 0 0"`` compiles in MuJoCo; every command refuses it in one line naming
    the element (no ``position error nan``), MuJoCo's own warning becomes a note on
    stderr (not stdout), and no ``MUJOCO_LOG.TXT`` is left in the current folder."""
    model = tmp_path / "arm.xml"
    model.write_text(NAN_ARM)
    args = {
        "solve": ["solve", "--model", str(model), "--site", "tip", "--target", "0.3,0.2,0"],
        "inspect": ["inspect", "--model", str(model)],
        "bench": ["bench", "--model", str(model), "--site", "tip", "--n", "3"],
    }[command]
    done = subprocess.run(
        [sys.executable, "-m", "humanoid_ik", *args], capture_output=True, cwd=tmp_path, timeout=120
    )
    err = done.stderr.decode().strip().splitlines()
    assert done.returncode == 2 and done.stdout == b"", done
    assert err[-1] == (
        f"humanoid-ik: error: model '{model}': body 'fore' pos is not finite (nan 0 0); "
        "every number must be"
    ), err
    assert all(line.startswith("humanoid-ik: note: MuJoCo: ") for line in err[:-1]), err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
