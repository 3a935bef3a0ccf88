"""The one table of a scene run: every frame's full ``qpos``, its samples (one per
effector) and its targets' orientations.

:class:`Recording` is the runner's frame sink (:meth:`SceneRunner.run
<humanoid_ik.run.runner.SceneRunner.run>` returns it). Everything a run writes is
derived from it: ``metrics.csv``/``metrics.json`` (:meth:`Recording.rows`,
:meth:`Recording.to_dict`), the trajectory files (:meth:`Recording.trajectory`, every
sample field kept, so a replay's frames equal the run's) and the summary.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from humanoid_ik.config.specs import Scene
from humanoid_ik.core.chain import Chain
from humanoid_ik.core.model_files import model_digest
from humanoid_ik.core.robot import joint_name
from humanoid_ik.motion import TargetTrack
from humanoid_ik.run.metrics import CSV_FIELDS, FrameSamples
from humanoid_ik.run.trajectory import EffectorTrack, Trajectory, qpos_names

__all__ = ["Recording"]


class Recording:
    """Every frame of a run: its ``qpos``, its samples and its targets' orientations.

    Args:
        scene: the scene that runs.
        solvers: each effector's solver label (scene order).
        model: the scene's model (for the trajectory's ``qpos`` columns).
        chains: each effector's chain (scene order).
        targets: each effector's target track (scene order), for pose targets'
            orientation.

    Attributes:
        frames: every frame's samples (:class:`FrameSamples`), in order.
        qpos: every frame's full ``qpos`` ``(nq,)``.
        frame_times: wall time of each frame in the runner's loop [s] (solve,
            ``mj_forward``, measuring and every output taking the frame); not exported.
        interrupted: Ctrl-C stopped the run early.
    """

    def __init__(
        self,
        scene: Scene,
        solvers: Sequence[str],
        model: mujoco.MjModel | None = None,
        chains: Sequence[Chain] = (),
        targets: Sequence[TargetTrack] = (),
    ):
        self.scene = scene
        self.solvers = list(solvers)
        self.model = model
        self.chains = list(chains)
        self.targets = list(targets)
        self.frames: list[FrameSamples] = []
        self.qpos: list[NDArray[np.float64]] = []
        self._quats: list[Sequence[NDArray[np.float64] | None]] = []
        self._orientations = [t.orientation for t in self.targets]
        # a frame without pose targets keeps this one row of Nones
        self._no_quats = (None,) * len(self.targets)
        self._posed = any(o is not None for o in self._orientations)
        self.frame_times: list[float] = []
        self.interrupted = False

    needs_forward = False
    """A recording reads ``qpos`` only: the runner may skip ``mj_forward`` for it."""

    def __len__(self) -> int:
        return len(self.frames)

    def add_frame(self, frame: FrameSamples, data: mujoco.MjData) -> None:
        """Keep ``frame`` with ``data``'s ``qpos`` and the targets' orientations
        (as a sink of the runner's loop)."""
        self.frames.append(frame)
        self.qpos.append(data.qpos.copy())
        if not self._posed:
            self._quats.append(self._no_quats)
            return
        t = frame.time
        self._quats.append(
            [None if o is None else np.asarray(o.quat_at(t)) for o in self._orientations]
        )

    def series(self, effector: int, attribute: str) -> NDArray[np.float64]:
        """One attribute of one effector over the frames ``(frames,)`` (``None`` -> NaN)."""
        vals = [getattr(f.samples[effector], attribute) for f in self.frames]
        return np.array([math.nan if v is None else v for v in vals], dtype=np.float64)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per frame and effector, keyed like the CSV columns."""
        out = []
        for f in self.frames:
            for s in f.samples:
                out.append(
                    {
                        "frame": f.index,
                        "time_s": f.time,
                        "effector": s.effector,
                        "target_name": s.target_name,
                        "task": s.task,
                        "target_x": float(s.target[0]),
                        "target_y": float(s.target[1]),
                        "target_z": float(s.target[2]),
                        "achieved_x": float(s.achieved[0]),
                        "achieved_y": float(s.achieved[1]),
                        "achieved_z": float(s.achieved[2]),
                        "position_error_m": s.position_error,
                        "orientation_error_rad": s.orientation_error,
                        "iterations": s.iterations,
                        "solve_time_s": s.solve_time,
                        "limit_margin_rad": s.limit_margin,
                        "reachable": s.reachable,
                        "on_target": s.on_target,
                        "status": s.status,
                    }
                )
        return out

    def summary(self) -> list[dict[str, Any]]:
        """Per effector: frames, reachable frames, share on target while reachable, worst
        and median position error while reachable [m], median and worst solve time [s]."""
        out = []
        for k, eff in enumerate(self.scene.effectors):
            err = self.series(k, "position_error")
            reach = self.series(k, "reachable").astype(bool)
            on = self.series(k, "on_target").astype(bool)
            st = self.series(k, "solve_time")
            er = err[reach]
            out.append(
                {
                    "effector": eff.name,
                    "target": eff.target,
                    "task": eff.task,
                    "solver": self.solvers[k],
                    "frames": len(self.frames),
                    "reachable_frames": int(reach.sum()),
                    "on_target_when_reachable": float(on[reach].mean()) if er.size else None,
                    "max_position_error_reachable_m": float(er.max()) if er.size else None,
                    "median_position_error_reachable_m": float(np.median(er)) if er.size else None,
                    "median_solve_time_s": float(np.median(st)) if st.size else None,
                    "max_solve_time_s": float(st.max()) if st.size else None,
                    "max_iterations": int(self.series(k, "iterations").max()) if self.frames else 0,
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the scene, the summary and every sample."""
        sc = self.scene
        return {
            "scene": sc.name,
            "source": sc.source,
            "fps": sc.fps,
            "frames": len(self.frames),
            "interrupted": self.interrupted,
            "effectors": [
                {e.kind: e.name, "target": e.target, "task": e.task, "solver": s}
                for e, s in zip(sc.effectors, self.solvers, strict=True)
            ],
            "summary": self.summary(),
            "samples": self.rows(),
        }

    def csv_text(self) -> str:
        """The samples as CSV text (one row per frame and effector)."""
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=CSV_FIELDS, lineterminator="\n")
        w.writeheader()
        for row in self.rows():
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()

    # ----------------------------------------------------------------- trajectory files
    def _track(self, k: int, qpos: NDArray[np.float64]) -> EffectorTrack:
        eff, chain = self.scene.effectors[k], self.chains[k]
        samples = [r.samples[k] for r in self.frames]
        n = len(samples)
        posed = self.targets[k].orientation is not None

        def column(name: str, dtype: type) -> NDArray[Any]:
            vals = [getattr(s, name) for s in samples]
            if dtype is float:
                vals = [math.nan if v is None else v for v in vals]
            return np.array(vals, dtype=dtype).reshape(n)

        return EffectorTrack(
            site=eff.name,
            target_name=eff.target,
            task=eff.task,
            solver=self.solvers[k],
            joints=tuple(chain.joint_names),
            q=qpos[:, chain.qpos_adr] if n else np.zeros((0, chain.n)),
            target=np.array([s.target for s in samples]).reshape(n, 3),
            target_quat=np.array([q[k] for q in self._quats]).reshape(n, 4) if posed else None,
            achieved=np.array([s.achieved for s in samples]).reshape(n, 3),
            position_error=column("position_error", float),
            on_target=column("on_target", bool),
            reachable=column("reachable", bool),
            status=tuple(s.status for s in samples),
            orientation_error=column("orientation_error", float),
            iterations=column("iterations", int),
            solve_time=column("solve_time", float),
            limit_margin=column("limit_margin", float),
            kind=eff.kind,
        )

    def trajectory(self) -> Trajectory:
        """The frames recorded so far as a :class:`Trajectory` (what the trajectory files
        hold), every sample field kept.

        Raises:
            ValueError: the recording was made without its model and chains.
        """
        m = self.model
        if m is None or len(self.chains) != len(self.scene.effectors):
            raise ValueError("a trajectory needs the recording's model, chains and targets")
        qpos = np.array(self.qpos, dtype=np.float64).reshape(len(self.qpos), m.nq)
        sc = self.scene
        return Trajectory(
            time=np.array([r.time for r in self.frames], dtype=np.float64),
            qpos=qpos,
            qpos_names=tuple(qpos_names(m)),
            joint_names=tuple(joint_name(m, j) for j in range(m.njnt)),
            effectors=tuple(self._track(k, qpos) for k in range(len(sc.effectors))),
            fps=float(sc.fps),
            scene=sc.name,
            scene_file="" if sc.path is None else str(sc.path),
            model_file=str(sc.model),
            model_sha256=model_digest(sc.model, packages=sc.packages),
            render=sc.render,
            interrupted=self.interrupted,
            stage_points=sc.target_points(),
        )
