"""Every bad trajectory file of the attack on the trajectory readers (issue 24: names
that escape ``--out``, NaN and infinities, malformed CSV and npz, zip bombs, oversize
frame counts, duplicate columns) fed to ``replay``, ``export-bvh``, ``export-keyframes``
and the Python reader: one line naming the field, the value and the rule, exit 2, and
nothing written in the output folder, its sibling or anywhere the name points to. A zip
bomb costs no memory: a member inflating to 4 GB is never inflated (measured with
``getrusage`` in a subprocess, bound :data:`BOMB_MB`).

Good files are made by ``humanoid-ik run circle --frames 5`` and edited."""

from __future__ import annotations

import io
import json
import os
import struct
import subprocess
import sys
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from humanoid_ik.cli import main
from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.outputs.trajectory import load_trajectory

BOMB_MB = 64
"""Most memory [MB] reading a bomb may take beyond reading the good file it was made
from, in a fresh process (max RSS, ``resource.getrusage``)."""


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """A run of ``circle`` of 5 frames: its trajectory.npz and trajectory.csv."""
    out = tmp_path_factory.mktemp("good") / "run"
    assert main(["run", "circle", "--frames", "5", "--out", str(out)]) == 0
    return out


def _arrays(good: Path) -> dict[str, np.ndarray]:
    with np.load(good / "trajectory.npz") as z:
        return {k: z[k] for k in z.files}


def _npz(path: Path, arrays: dict[str, np.ndarray], header: dict | None = None) -> Path:
    if header is not None:
        arrays = {**arrays, "header": np.array(json.dumps(header))}
    np.savez(path, **arrays)
    return path


def header_edit(**changes) -> Callable[[Path, Path], Path]:
    """A trajectory.npz whose header has ``changes`` (a ``render.x`` key edits the
    render block; the value ``...`` deletes the key)."""

    def make(good: Path, d: Path) -> Path:
        arrays = _arrays(good)
        header = json.loads(str(arrays["header"]))
        for key, value in changes.items():
            node, _, leaf = (
                (header["render"], None, key[7:])
                if key.startswith("render_")
                else (
                    header,
                    None,
                    key,
                )
            )
            if value is ...:
                del node[leaf]
            else:
                node[leaf] = value
        return _npz(d / "trajectory.npz", arrays, header)

    return make


def array_edit(name: str, fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[Path, Path], Path]:
    """A trajectory.npz whose member ``name`` is ``fn(member)``."""

    def make(good: Path, d: Path) -> Path:
        arrays = _arrays(good)
        arrays[name] = fn(arrays[name])
        return _npz(d / "trajectory.npz", arrays)

    return make


def csv_edit(fn: Callable[[list[str]], list[str]]) -> Callable[[Path, Path], Path]:
    """A trajectory.csv whose lines are ``fn(lines)``."""

    def make(good: Path, d: Path) -> Path:
        lines = (good / "trajectory.csv").read_text().splitlines()
        path = d / "trajectory.csv"
        path.write_text("\n".join(fn(lines)) + "\n")
        return path

    return make


def raw(name: str, data: bytes) -> Callable[[Path, Path], Path]:
    def make(good: Path, d: Path) -> Path:
        (d / name).write_bytes(data)
        return d / name

    return make


def _cell(lines: list[str], row: int, col: str, value: str) -> list[str]:
    """``lines`` with the cell of column ``col`` in data row ``row`` set to ``value``."""
    cols = lines[1].split(",")
    cells = lines[2 + row].split(",")
    cells[cols.index(col)] = value
    return [*lines[: 2 + row], ",".join(cells), *lines[3 + row :]]


def _header_line(lines: list[str], **changes) -> list[str]:
    header = json.loads(lines[0][2:])
    header.update(changes)
    return ["# " + json.dumps(header), *lines[1:]]


def _bomb(name: str, size: int = 4_000_000_000) -> Callable[[Path, Path], Path]:
    """The good npz with one more member, ``name``: an array of ``uint8`` zeros whose
    ``.npy`` header and the archive's directory both say (truthfully) ``size`` bytes,
    about 4 MB on disk. Reading every member, as ``numpy.load`` users do, allocates it."""

    def make(good: Path, d: Path) -> Path:
        path = d / "trajectory.npz"
        path.write_bytes((good / "trajectory.npz").read_bytes())
        _append_bomb(path, name, _npy_header((size,), "|u1"), size)
        return path

    return make


def _bomb_known(good: Path, d: Path) -> Path:
    """The good npz whose ``qpos`` member has its true array header and data, then
    zeros up to 4 GB, all within the size the archive declares for it."""
    arrays = _arrays(good)
    qpos = arrays.pop("qpos")
    path = _npz(d / "trajectory.npz", arrays)
    prefix = _npy_header(qpos.shape, "<f8") + qpos.tobytes()
    _append_bomb(path, "qpos.npy", prefix, 4_000_000_000)
    return path


def _npy_header(shape: tuple[int, ...], descr: str) -> bytes:
    buf = io.BytesIO()
    head = {"descr": descr, "fortran_order": False, "shape": shape}
    np.lib.format.write_array_header_1_0(buf, head)
    return buf.getvalue()


def _append_bomb(path: Path, name: str, prefix: bytes, zeros: int) -> None:
    """Add member ``name`` to the zip at ``path``: ``prefix`` then ``zeros`` zero bytes,
    deflated from one full-flushed 1 MiB block repeated (no 4 GB is compressed or
    checksummed: :func:`_crc_zeros`), under honest sizes and CRC."""
    chunk = 2**20
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    head = c.compress(prefix) + c.flush(zlib.Z_FULL_FLUSH)
    block = c.compress(bytes(chunk)) + c.flush(zlib.Z_FULL_FLUSH)
    n, rest = divmod(zeros, chunk)
    data = head + block * n + c.compress(bytes(rest)) + c.flush()
    size = len(prefix) + zeros
    crc = _crc_zeros(zeros, zlib.crc32(prefix))
    with zipfile.ZipFile(path, "a") as zf:
        info = zipfile.ZipInfo(name, date_time=(2024, 1, 1, 0, 0, 0))
        zf.writestr(info, data)  # stored; the method and sizes are patched below
        offset = zf.getinfo(name).header_offset
    blob = bytearray(path.read_bytes())
    central = blob.rfind(b"PK\x01\x02")
    assert blob[central + 46 : central + 46 + len(name)] == name.encode()
    for at in (offset + 8, central + 10):  # local header, then the directory's entry
        struct.pack_into("<H", blob, at, zipfile.ZIP_DEFLATED)
        struct.pack_into("<III", blob, at + 6, crc, len(data), size)
    path.write_bytes(bytes(blob))


def _crc_zeros(n: int, crc: int = 0) -> int:
    """``zlib.crc32(bytes(n), crc)`` without running over ``n`` bytes: a zero byte acts
    on the CRC register as a linear map over GF(2), raised to the ``n``-th power by
    squaring (the method of zlib's ``crc32_combine``)."""

    def times(mat: list[int], vec: int) -> int:
        out, i = 0, 0
        while vec:
            if vec & 1:
                out ^= mat[i]
            vec, i = vec >> 1, i + 1
        return out

    def square(mat: list[int]) -> list[int]:
        return [times(mat, mat[i]) for i in range(32)]

    op = [0xEDB88320] + [1 << i for i in range(31)]  # one zero bit
    for _ in range(3):
        op = square(op)  # one zero byte
    reg = crc ^ 0xFFFFFFFF
    while n:
        if n & 1:
            reg = times(op, reg)
        op, n = square(op), n >> 1
    return reg ^ 0xFFFFFFFF


def test_the_bomb_builder_is_honest(good, tmp_path):
    """The CRC shortcut is zlib's, and a bomb of 20 MB reads back with numpy.load
    (CRC checked by zipfile) as its zeros: the 4 GB one is the same but larger."""
    for n, start in ((0, 0), (1, 0), (7, 5), (1000, 0xDEADBEEF), (2**20 + 3, 1)):
        assert _crc_zeros(n, start) == zlib.crc32(bytes(n), start)
    small = _bomb("junk.npy", 20 * 2**20 + 5)(good, tmp_path)
    with np.load(small) as z:
        junk = z["junk"]
    assert junk.shape == (20 * 2**20 + 5,) and not junk.any()


ESCAPE = "../victim/important"
"""A scene name that leads out of ``--out`` (``out/../victim/important.mp4``)."""

CASES: dict[str, tuple[Callable[[Path, Path], Path], str]] = {
    # names that become paths
    "scene escapes": (header_edit(scene=ESCAPE), "scene: expected a name of letters"),
    "scene absolute": (header_edit(scene="/tmp/elsewhere/x"), "scene: expected a name"),
    "scene empty": (header_edit(scene=""), "scene: expected a name"),
    "scene dot-dot": (header_edit(scene=".."), "scene: expected a name"),
    "scene not a string": (header_edit(scene=7), "scene: expected a name"),
    # header numbers and types
    "fps text": (header_edit(fps="abc"), "fps: expected a number >= 0.01 and <= 1000, got 'abc'"),
    "fps tiny": (header_edit(fps=1e-300), "fps: expected a number >= 0.01"),
    "fps huge": (header_edit(fps=1e300), "fps: expected a number >= 0.01 and <= 1000, got 1e+300"),
    "fps 1e6": (header_edit(fps=1e6), "fps: expected a number >= 0.01 and <= 1000"),
    "fps NaN": (header_edit(fps=float("nan")), "fps: expected a number"),
    "fps missing": (header_edit(fps=...), "fps: missing; expected a number >= 0.01"),
    "frames oversize": (
        header_edit(frames=1_000_000),
        "frames: expected an integer >= 1 and <= 100000, got 1000000",
    ),
    "frames disagree": (header_edit(frames=100_000), "time: expected shape (100000,), got (5,)"),
    "frames zero": (header_edit(frames=0), "frames: expected an integer >= 1"),
    "interrupted no": (
        header_edit(interrupted="no"),
        "interrupted: expected true or false, got 'no'",
    ),
    "interrupted 1": (header_edit(interrupted=1), "interrupted: expected true or false, got 1"),
    "digest": (header_edit(model_sha256="x" * 16), "model_sha256: expected 16 hex digits"),
    "unknown key": (header_edit(extra=1), "extra: unknown key; expected one of"),
    "qpos names twice": (
        header_edit(qpos_names=["a"] * 16),
        "qpos_names: expected a list of distinct names",
    ),
    "effector joint": (
        lambda g, d: _effector_edit(g, d, joints=["nope"]),
        "effectors[0].joints[0]: expected one of qpos_names, got 'nope'",
    ),
    "effector task": (
        lambda g, d: _effector_edit(g, d, task="fly"),
        "effectors[0].task: expected one of 'reach', 'look_at', got 'fly'",
    ),
    "effector no end": (
        lambda g, d: _effector_edit(g, d, site=...),
        "effectors[0].site: expected a site or a body",
    ),
    "stage point NaN": (
        header_edit(stage_points=[[float("nan"), 0, 0]]),
        "stage_points[0]: expected a point [x, y, z] of finite numbers",
    ),
    # the render block, with the scene files' bounds
    "width odd": (
        header_edit(render_width=97),
        "render.width: expected an even integer >= 16 and <= 4096 (pixels), got 97",
    ),
    "width huge": (header_edit(render_width=10**9), "render.width: expected an even integer"),
    "width text": (header_edit(render_width="640"), "render.width: expected an even integer"),
    "trail NaN": (
        header_edit(render_trail=float("nan")),
        "render.trail: expected a number >= 0 and <= 60",
    ),
    "trail huge": (
        header_edit(render_trail=1e300),
        "render.trail: expected a number >= 0 and <= 60, got 1e+300",
    ),
    "trail text": (header_edit(render_trail="x"), "render.trail: expected a number"),
    "snapshots text": (
        header_edit(render_snapshots="x"),
        "render.snapshots: expected a list of at most 100 times",
    ),
    "snapshots many": (
        header_edit(render_snapshots=[0.0] * 101),
        "render.snapshots: expected at most 100 times, got 101",
    ),
    "snapshot NaN": (
        header_edit(render_snapshots=[float("nan")]),
        "render.snapshots[0]: expected a number >= 0",
    ),
    "sheet huge": (
        header_edit(render_contact_sheet=10**9),
        "render.contact_sheet: expected an integer >= 0 and <= 100",
    ),
    "render unknown": (header_edit(render_fov=3), "render.fov: unknown key"),
    # the arrays
    "qpos NaN": (
        array_edit("qpos", lambda a: np.where(np.arange(a.size).reshape(a.shape) == 3, np.nan, a)),
        "qpos[0, 3] (frame 0, column 'right_shoulder_abduction_joint'): expected finite "
        "numbers, got nan",
    ),
    "qpos inf": (
        array_edit("qpos", lambda a: a + np.inf),
        "qpos[0, 0] (frame 0, column 'neck_yaw_joint'): expected finite numbers, got inf",
    ),
    "qpos complex": (
        array_edit("qpos", lambda a: a.astype(complex)),
        "qpos: expected numbers, got dtype complex128",
    ),
    "qpos text": (
        array_edit("qpos", lambda a: a.astype(str)),
        "qpos: expected numbers, got dtype <U",
    ),
    "qpos shape": (
        array_edit("qpos", lambda a: a[:, :3]),
        "qpos: expected shape (5, 16), got (5, 3)",
    ),
    "time NaN": (
        array_edit("time", lambda a: a * np.nan),
        "time[0] (frame 0, column 'time_s'): expected finite numbers >= 0 and <= 1e+07, got nan",
    ),
    "time negative": (
        array_edit("time", lambda a: a - 1),
        "time[0] (frame 0, column 'time_s'): expected finite numbers >= 0 and <= 1e+07, got -1.0",
    ),
    "time goes back": (
        array_edit("time", lambda a: a[::-1].copy()),
        "time[1] (frame 1): expected a time >= the frame before's (3.2), got 2.4",
    ),
    "target inf": (
        array_edit("effector0_target", lambda a: a + np.inf),
        "effector0_target[0, 0] (frame 0, column 'right_palm_site.target_x'): expected "
        "finite numbers >= -1e+06 and <= 1e+06, got inf",
    ),
    "target far": (
        array_edit("effector0_target", lambda a: a + 1e300),
        "effector0_target[0, 0] (frame 0, column 'right_palm_site.target_x'): expected "
        "finite numbers >= -1e+06 and <= 1e+06, got 1e+300",
    ),
    "achieved NaN": (
        array_edit("effector0_achieved", lambda a: a * np.nan),
        "effector0_achieved[0, 0] (frame 0, column 'right_palm_site.achieved_x'): expected finite",
    ),
    "stage member NaN": (
        array_edit("stage_points", lambda a: a * np.nan),
        "stage_points[0, 0]: expected finite",
    ),
    "status unknown": (
        array_edit("effector0_status", lambda a: np.array(["won"] * 5)),
        "effector0_status: expected one of converged, max_iterations, unreachable, got 'won'",
    ),
    "iterations fractional": (
        array_edit("effector0_iterations", lambda a: a + 0.5),
        "effector0_iterations[0] (frame 0, column 'right_palm_site.iterations'): expected "
        "whole numbers >= 0, got 5.5",
    ),
    "q not qpos": (
        array_edit("effector0_q", lambda a: a + 1),
        "effector0_q: expected the qpos columns of its joints",
    ),
    "flags as text": (
        array_edit("effector0_on_target", lambda a: a.astype(str)),
        "effector0_on_target: expected booleans, got dtype <U",
    ),
    "object array": (
        array_edit("qpos", lambda a: a.astype(object)),
        "qpos: expected numbers, got dtype object",
    ),
    "member missing": (
        lambda g, d: _npz(
            d / "trajectory.npz", {k: v for k, v in _arrays(g).items() if k != "qpos"}
        ),
        "lacks the array 'qpos'",
    ),
    # broken archives
    "npz empty": (raw("trajectory.npz", b""), "not an .npz (zip) archive"),
    "npz random": (raw("trajectory.npz", os.urandom(5000)), "not an .npz (zip) archive"),
    "npz no header": (
        lambda g, d: _npz(d / "t.npz", {"time": np.zeros(2)}),
        "is not a humanoid-ik trajectory file",
    ),
    "header not JSON": (
        lambda g, d: _npz(d / "t.npz", {**_arrays(g), "header": np.array("{oops")}),
        "has a header that is not JSON",
    ),
    "header deep JSON": (
        lambda g, d: _npz(d / "t.npz", {**_arrays(g), "header": np.array("[" * 100_000)}),
        "has a header that is not JSON",
    ),
    "header not text": (
        lambda g, d: _npz(d / "t.npz", {**_arrays(g), "header": np.zeros(3)}),
        "header: expected text, got dtype float64",
    ),
    "member declares 1e12": (
        lambda g, d: _declared(g, d, "qpos.npy", (10**12,)),
        "qpos: expected shape (5, 16), got (1000000000000,)",
    ),
    "bomb known member": (
        _bomb_known,
        "qpos: the archive declares 4000000768 bytes for it; its array takes 768",
    ),
    # CSV
    "csv empty": (raw("trajectory.csv", b""), "is not a humanoid-ik trajectory file"),
    "csv random": (raw("trajectory.csv", os.urandom(5000)), "is not a humanoid-ik trajectory file"),
    "csv header only": (csv_edit(lambda ls: ls[:1]), "has no line of column names"),
    "csv no rows": (csv_edit(lambda ls: ls[:2]), "has 0 row(s); its header says frames = 5"),
    "csv short row": (
        csv_edit(lambda ls: [*ls[:3], ",".join(ls[3].split(",")[:-2]), *ls[4:]]),
        "line 4 has 30 cells; expected 32 (one per column)",
    ),
    "csv long row": (
        csv_edit(lambda ls: [*ls[:3], ls[3] + ",1", *ls[4:]]),
        "line 4 has 33 cells; expected 32",
    ),
    "csv text cell": (
        csv_edit(lambda ls: _cell(ls, 2, "time_s", "abc")),
        "line 5, column 'time_s': expected a number, got 'abc'",
    ),
    "csv flag cell": (
        csv_edit(lambda ls: _cell(ls, 1, "right_palm_site.on_target", "yes")),
        "line 4, column 'right_palm_site.on_target': expected 0 or 1, got 'yes'",
    ),
    "csv NaN cell": (
        csv_edit(lambda ls: _cell(ls, 0, "right_elbow_joint", "nan")),
        "qpos[0, 5] (frame 0, column 'right_elbow_joint'): expected finite numbers, got nan",
    ),
    "csv inf fps": (
        csv_edit(lambda ls: _header_line(ls, fps=float("inf"))),
        "fps: expected a number >= 0.01 and <= 1000, got inf",
    ),
    "csv frame cell": (
        csv_edit(lambda ls: _cell(ls, 1, "frame", "7")),
        "line 4, column 'frame': expected 1, got '7'",
    ),
    "csv missing column": (
        csv_edit(lambda ls: [ls[0], *(",".join(r.split(",")[:-1]) for r in ls[1:])]),
        "lacks column 'right_palm_site.limit_margin_rad'",
    ),
    "csv duplicate column": (
        csv_edit(lambda ls: [ls[0], ls[1].replace("neck_pitch_joint", "neck_yaw_joint"), *ls[2:]]),
        "column 'neck_yaw_joint' appears twice (columns 3 and 4)",
    ),
    "csv unknown column": (
        csv_edit(lambda ls: [ls[0], ls[1].replace("neck_pitch_joint", "knee"), *ls[2:]]),
        "lacks column 'neck_pitch_joint'",
    ),
    "csv more rows": (
        csv_edit(lambda ls: [*ls, ls[-1]]),
        "has more than 5 rows; its header says frames = 5",
    ),
    "csv oversize": (
        csv_edit(lambda ls: _header_line(ls, frames=10**7)),
        "frames: expected an integer >= 1 and <= 100000",
    ),
    "csv scene escapes": (
        csv_edit(lambda ls: _header_line(ls, scene=ESCAPE)),
        "scene: expected a name",
    ),
    "csv status": (
        csv_edit(lambda ls: _cell(ls, 0, "right_palm_site.status", "won")),
        "effector0_status: expected one of converged",
    ),
}


def _effector_edit(good: Path, d: Path, **changes) -> Path:
    arrays = _arrays(good)
    header = json.loads(str(arrays["header"]))
    for key, value in changes.items():
        if value is ...:
            del header["effectors"][0][key]
        else:
            header["effectors"][0][key] = value
    return _npz(d / "trajectory.npz", arrays, header)


def _declared(good: Path, d: Path, member: str, shape: tuple[int, ...]) -> Path:
    """The good npz with ``member``'s array header declaring ``shape`` (data unchanged)."""
    path = d / "trajectory.npz"
    with zipfile.ZipFile(good / "trajectory.npz") as src, zipfile.ZipFile(path, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            if info.filename == member:
                arr = np.load(io.BytesIO(data))
                data = _npy_header(shape, arr.dtype.str) + arr.tobytes()
            dst.writestr(info.filename, data)
    return path


@pytest.fixture()
def folders(tmp_path, monkeypatch):
    """``tmp/run`` (the bad file's folder and cwd: a default output folder lands in
    it), ``tmp/out`` (--out), ``tmp/sibling`` (stays empty) and ``tmp/victim`` (where
    an escaping name points: never created)."""
    run = tmp_path / "run"
    run.mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "sibling").mkdir()
    monkeypatch.chdir(run)
    return tmp_path


def _nothing_written(tmp: Path, bad: Path) -> None:
    assert not any((tmp / "out").iterdir())
    assert not any((tmp / "sibling").iterdir())
    assert not (tmp / "victim").exists() and not Path("/tmp/elsewhere").exists()
    assert sorted(p.name for p in (tmp / "run").iterdir()) == [bad.name]


@pytest.mark.parametrize("case", list(CASES))
def test_every_reader_refuses_it_in_one_line(good, folders, capsys, case):
    make, message = CASES[case]
    bad = make(good, folders / "run")
    with pytest.raises(TrajectoryFileError) as err:
        load_trajectory(bad)
    text = str(err.value)
    assert "\n" not in text and message in text, text
    assert "allow_pickle" not in text and "Traceback" not in text
    out = folders / "out"
    for argv in (
        ["replay", str(bad), "--out", str(out / "r")],
        ["replay", str(bad)],
        ["export-bvh", str(bad), "--out", str(out / "m.bvh")],
        ["export-keyframes", str(bad), "--out", str(out / "k.xml")],
    ):
        assert main(argv) == 2, argv
        err_text = capsys.readouterr().err
        assert err_text.count("\n") == 1 and message in err_text, (argv, err_text)
        assert err_text.startswith("humanoid-ik: error: ")
    _nothing_written(folders, bad)


_RSS = """
import resource, sys
from humanoid_ik.cli import main
from humanoid_ik.outputs.trajectory import load_trajectory
from humanoid_ik.errors import TrajectoryFileError
path, out = sys.argv[1], sys.argv[2]
try:
    load_trajectory(path)
    read = "read"
except TrajectoryFileError as exc:
    read = "refused"
code = main(["export-keyframes", path, "--out", out])
print(read, code, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024)
"""


def _max_rss(path: Path, out: Path) -> tuple[str, int, int]:
    """``(read or refused, export-keyframes' exit status, max RSS [MB])`` of a fresh
    process that reads ``path`` with the Python reader and exports it."""
    proc = subprocess.run(
        [sys.executable, "-c", _RSS, str(path), str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    read, code, mb = proc.stdout.split()[-3:]
    return read, int(code), int(mb)


def test_a_zip_bomb_is_never_inflated(good, tmp_path):
    """A 4 MB npz whose unused member inflates to 4 GB (numpy.load's users allocate
    it) reads in the memory of the good file it was made from, within BOMB_MB: the
    member is never opened. One whose ``qpos`` inflates to 4 GB past its array is
    refused from the sizes the archive declares, before anything is inflated."""
    unused = _bomb("junk.npy")(good, tmp_path)
    assert unused.stat().st_size < 8e6
    with zipfile.ZipFile(unused) as zf:
        assert zf.getinfo("junk.npy").file_size > 4e9
    _, _, base = _max_rss(good / "trajectory.npz", tmp_path / "base.xml")
    read, code, bomb = _max_rss(unused, tmp_path / "bomb.xml")
    assert (read, code) == ("read", 0) and bomb - base < BOMB_MB, (base, bomb)
    assert (tmp_path / "bomb.xml").read_text() == (tmp_path / "base.xml").read_text()
    known = tmp_path / "known"
    known.mkdir()
    read, code, bomb = _max_rss(_bomb_known(good, known), tmp_path / "known.xml")
    assert (read, code) == ("refused", 2) and bomb - base < BOMB_MB, (base, bomb)
    assert not (tmp_path / "known.xml").exists()


def test_replay_names_where_a_bad_render_setting_came_from(good, folders, capsys):
    """A camera or frame size the model cannot give is named as the trajectory's
    ``render.camera``/``render.width`` when no option gave it, as the option when one
    did; a missing ``--model`` is named as given. Nothing is written."""
    run = folders / "run"
    bad = header_edit(render_camera="nope")(good, run)
    assert main(["replay", str(bad), "--out", str(folders / "out" / "r")]) == 2
    err = capsys.readouterr().err
    assert f"trajectory '{bad}': render.camera 'nope' not in model; cameras: front" in err
    assert main(["replay", str(bad), "--camera", "nope2", "--out", str(folders / "out")]) == 2
    assert "--camera 'nope2' not in model" in capsys.readouterr().err
    wide = header_edit(render_width=2048)(good, run)
    assert main(["replay", str(wide), "--out", str(folders / "out" / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "render.width 2048: expected at most 1920 (the model's off-screen buffer" in err
    assert "EGL" not in err and "install" not in err
    good_npz = good / "trajectory.npz"
    argv = ["replay", str(good_npz), "--width", "2048", "--out", str(folders / "out" / "r")]
    assert main(argv) == 2
    assert "--width 2048: expected at most 1920" in capsys.readouterr().err
    gone = folders / "gone.xml"
    assert (
        main(
            [
                "export-bvh",
                str(good_npz),
                "--model",
                str(gone),
                "--out",
                str(folders / "out" / "m.bvh"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert f"model file '{gone}' does not exist\n" in err and "of trajectory" not in err
    assert not any((folders / "out").iterdir()) and not any((folders / "sibling").iterdir())


def test_the_checked_model_is_the_one_named(good, tmp_path, capsys):
    """A trajectory checked against ``--model``: the message names that file, not
    the one the trajectory was recorded on."""
    other = tmp_path / "other.xml"
    other.write_text(
        '<mujoco><worldbody><body><joint name="j"/><geom size=".1"/></body></worldbody></mujoco>'
    )
    out = tmp_path / "k.xml"
    assert (
        main(
            [
                "export-keyframes",
                str(good / "trajectory.npz"),
                "--model",
                str(other),
                "--out",
                str(out),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert f"does not fit model '{other}'" in err and "humanoid/scene.xml" not in err
    assert not out.exists()


def test_a_name_from_python_is_held_to_the_same_rule(good, tmp_path):
    """``render_scene``, ``write_run``, ``replay_trajectory`` and
    ``write_trajectory`` refuse a scene name that would lead out of the folder (or be
    empty, or a dot-name), whatever built the scene: nothing is written anywhere."""
    from dataclasses import replace

    from humanoid_ik.config.scene import load_scene
    from humanoid_ik.core.models import load_model
    from humanoid_ik.errors import SceneError
    from humanoid_ik.outputs.render.pipeline import render_scene, replay_trajectory
    from humanoid_ik.outputs.run_files import write_run
    from humanoid_ik.outputs.trajectory import write_trajectory

    scene = load_scene("circle").with_overrides(frames=2)
    out = tmp_path / "a" / "out"
    traj = load_trajectory(good / "trajectory.npz")
    for name in ("../../x", "/tmp/elsewhere/x", "", ".", "..", ".hidden", "a/b", "x" * 101):
        for run in (render_scene, write_run):
            with pytest.raises(SceneError, match=r"name: expected a name of letters"):
                run(replace(scene, name=name), out)
        with pytest.raises(TrajectoryFileError, match="scene: expected a name of letters"):
            replay_trajectory(replace(traj, scene=name), load_model(None), out, digest=None)
        with pytest.raises(TrajectoryFileError, match="scene: expected a name of letters"):
            write_trajectory(replace(traj, scene=name), out)
    assert sorted(tmp_path.iterdir()) == [] and not Path("/tmp/elsewhere").exists()


def test_mujoco_gl_that_names_no_backend(good, tmp_path):
    """``MUJOCO_GL=foo``: ``solve`` needs no GL and works; ``replay`` refuses it in one
    line naming the valid values, exit 2, before it makes its folder."""
    env = {**os.environ, "MUJOCO_GL": "foo"}
    cmd = [sys.executable, "-m", "humanoid_ik"]
    solve = subprocess.run(
        [*cmd, "solve", "--target=0.3,-0.2,1.2"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert solve.returncode == 0 and "converged" in solve.stdout, solve.stderr
    out = tmp_path / "r"
    replay = subprocess.run(
        [*cmd, "replay", str(good / "trajectory.npz"), "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert replay.returncode == 2 and replay.stderr.count("\n") == 1, replay.stderr
    assert (
        "MUJOCO_GL='foo' is not an OpenGL backend; expected one of egl, osmesa, glfw, glx"
        in replay.stderr
    )
    assert not out.exists()


def test_inspect_shows_huge_ranges_compactly(tmp_path, capsys):
    """A range of +-1e300 prints as ``+1e+300``, not 300 digits."""
    model = tmp_path / "big.xml"
    model.write_text(
        '<mujoco><compiler angle="radian"/><worldbody><body name="a"><joint name="j" '
        'range="-1e300 1e300" limited="true"/><geom type="capsule" size=".02" '
        'fromto="0 0 0 .3 0 0"/><site name="tip" pos=".3 0 0"/></body></worldbody></mujoco>'
    )
    assert main(["inspect", "--model", str(model)]) == 0
    text = capsys.readouterr().out
    row = next(line for line in text.splitlines() if line.strip().startswith("j  hinge"))
    assert "-1e+300 .. +1e+300" in row and len(row) < 120, row
