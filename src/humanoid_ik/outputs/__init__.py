"""The outputs layer: what a run leaves behind. ``atomic`` writes every file whole or not
at all; ``run_files`` runs a scene without rendering and writes its metrics and trajectory;
``trajectory`` writes and reads ``trajectory.npz``/``.csv``; ``bvh`` and ``keyframes``
export a trajectory for animation tools and for MuJoCo; ``render`` films a scene run or
replays a trajectory (backend, drawing, video, stills, plots, pipeline); ``viewer`` is
the live interactive viewer."""
