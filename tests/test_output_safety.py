"""What the tool writes lands where ``--out`` says and nowhere else: a device, a FIFO or
a socket given as an output is refused in one line and left as it was; a symbolic link
is written through (the link kept, its file replaced)."""

from __future__ import annotations

import json
import os
import socket

import pytest

from humanoid_ik.cli import main
from humanoid_ik.experiments.dataset import read_dataset
from humanoid_ik.outputs.atomic import write_text

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


UNLIMITED_ARM = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="0 0 1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.03"/>
        <site name="tip" pos="0.25 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
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
