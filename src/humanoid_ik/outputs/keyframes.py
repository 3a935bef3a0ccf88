"""A trajectory as MuJoCo keyframes: a ``<keyframe>`` element with one ``<key>`` per
frame (``name``, ``time`` [s] and the full ``qpos``), to paste or ``<include>`` into the
model's MJCF (``docs/formats.md``). Numbers are written in full precision, so the keys
hold the trajectory's values exactly."""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.trajectory import Trajectory

__all__ = ["keyframes_xml"]


def keyframes_xml(traj: Trajectory, every: int = 1, prefix: str | None = None) -> str:
    """The ``<mujoco><keyframe>...</keyframe></mujoco>`` document of ``traj``.

    Args:
        traj: the trajectory.
        every: keep frames ``0, every, 2 every...``.
        prefix: key names are ``<prefix>_<frame index>`` (default: the scene's name).

    Raises:
        TrajectoryFileError: ``every`` is below 1.
    """
    if every < 1:
        raise TrajectoryFileError(f"every: expected an integer >= 1, got {every}")
    stem = traj.scene if prefix is None else prefix
    width = len(str(max(0, traj.n_frames - 1)))
    lines = [
        f"<!-- {traj.n_frames} frame(s) of scene {quoteattr(traj.scene)} on "
        f"{quoteattr(traj.model_file)} (model sha256 {traj.model_sha256}); qpos order: "
        f"{' '.join(traj.qpos_names)} -->",
        "<mujoco>",
        "  <keyframe>",
    ]
    for i in range(0, traj.n_frames, every):
        qpos = " ".join(repr(float(v)) for v in traj.qpos[i])
        name = quoteattr(f"{stem}_{i:0{width}d}")
        lines.append(f'    <key name={name} time="{float(traj.time[i])!r}" qpos="{qpos}"/>')
    lines += ["  </keyframe>", "</mujoco>"]
    return "\n".join(lines) + "\n"
