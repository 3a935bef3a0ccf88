"""Running a scene: the one frame loop (``runner``) and what it measured (``metrics``)."""
