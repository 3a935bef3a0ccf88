"""Human motion capture (BVH) retargeted onto a humanoid's arms and head
(``docs/retarget.md``).

- :mod:`.human`: the human side found by joint names (CMU, Mixamo, LAFAN1, ...), a
  mapping file to override;
- :mod:`.robot`: the robot's arms, head, speed limits and self-collision pairs;
- :mod:`.targets`: the human's motion scaled onto the robot, frame by frame;
- :mod:`.elbow`: the elbow's direction, as a swivel, a branch or null-space steps;
- :mod:`.plan`: a ``closed_form`` arm's swivel planned over the whole clip;
- :mod:`.speed`: a frame the speed limits do not allow exactly, position first;
- :mod:`.solve`: every frame solved (exact solvers, ``lm``, the QP);
- :mod:`.metrics`: the per-frame metrics, their summary and the plot;
- :mod:`.pipeline`: :func:`retarget` (one clip, its files, the film);
- :mod:`.folder`: :func:`retarget_folder` (every clip of a folder, resumable, one after
  the other or on the sweep's local pool or Ray).
"""

from humanoid_ik.errors import RetargetError
from humanoid_ik.experiments.retarget.folder import retarget_folder
from humanoid_ik.experiments.retarget.human import Mapping, find_human
from humanoid_ik.experiments.retarget.pipeline import (
    CLIP_FILES,
    FILM,
    FILM_FILES,
    RetargetResult,
    clip_name,
    retarget,
)
from humanoid_ik.experiments.retarget.solve import SOLVERS

__all__ = [
    "CLIP_FILES",
    "FILM",
    "FILM_FILES",
    "SOLVERS",
    "Mapping",
    "RetargetError",
    "RetargetResult",
    "clip_name",
    "find_human",
    "retarget",
    "retarget_folder",
]
