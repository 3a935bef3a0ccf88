"""The bottom layer: rotations, the kinematic chain, models, value types and the error measures."""
