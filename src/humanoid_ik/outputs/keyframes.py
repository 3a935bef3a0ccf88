"""A trajectory as MuJoCo keyframes: a ``<keyframe>`` element with one ``<key>`` per
frame (``name``, ``time`` [s] and the full ``qpos``), to paste or ``<include>`` into the
model's MJCF (``docs/formats.md``). Numbers are written in full precision, so the keys
hold the trajectory's values exactly."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from humanoid_ik.errors import TrajectoryFileError
from humanoid_ik.run.trajectory import Trajectory

__all__ = ["keyframes_xml"]


def keyframes_xml(traj: Trajectory, every: int = 1, prefix: str | None = None) -> str:
    """The ``<mujoco><keyframe>...</keyframe></mujoco>`` document of ``traj``, built with
    an XML writer (names and paths escaped; the leading comment made valid whatever
    they hold).

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
    root = ET.Element("mujoco")
    keyframe = ET.SubElement(root, "keyframe")
    for i in range(0, traj.n_frames, every):
        ET.SubElement(
            keyframe,
            "key",
            name=f"{stem}_{i:0{width}d}",
            time=repr(float(traj.time[i])),
            qpos=" ".join(repr(float(v)) for v in traj.qpos[i]),
        )
    ET.indent(root)
    about = (
        f"{traj.n_frames} frame(s) of scene '{traj.scene}' on '{traj.model_file}' (model "
        f"sha256 {traj.model_sha256}); qpos order: {' '.join(traj.qpos_names)}"
    )
    return f"<!-- {_comment_text(about)} -->\n{ET.tostring(root, encoding='unicode')}\n"


def _comment_text(text: str) -> str:
    """``text`` as an XML comment may hold it: no ``--`` (a scene named ``a--b``), no
    control character."""
    text = re.sub(r"[\x00-\x08\x0b\x0c\x0e-\x1f]", "?", text)
    return re.sub(r"-(?=-)", "- ", text)
