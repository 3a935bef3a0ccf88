"""The Jacobian family: the shared loop and seed library, and its step rules
(transpose, pseudo-inverse, damped least squares)."""

import mujoco  # noqa: F401  (loads libmujoco, which the compiled module links to: setup.py)

# the family's compiled module (_lm_kernel.c): lm's loop and the seed library's ranking
try:
    from humanoid_ik.solvers.jacobian import _lm_kernel  # noqa: F401
except ImportError as exc:  # not built (a bare checkout) or built for another MuJoCo
    raise ImportError(
        f"humanoid_ik: lm's compiled kernel does not load ({exc}); build it with "
        "pip install . (pip install -e . in a checkout; it needs a C compiler)"
    ) from exc
