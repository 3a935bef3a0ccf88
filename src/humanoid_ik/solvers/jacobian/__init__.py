"""The Jacobian family: the shared loop and seed library, and its step rules
(transpose, pseudo-inverse, damped least squares)."""
