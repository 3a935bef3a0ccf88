"""Running a scene: the one frame loop (``runner``), what it measured (``metrics``), the
motion it produced (``trajectory``: the typed trajectory and its recorder) and playing a
recorded motion back (``replay``)."""
