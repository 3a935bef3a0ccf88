"""The outputs layer: what a run leaves behind. ``atomic`` writes every file whole or not
at all; ``render`` films a scene run (backend, drawing, video, stills, plots, pipeline)."""
