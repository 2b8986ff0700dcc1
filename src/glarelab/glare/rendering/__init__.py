"""Applying glare: the plan, the renderer, convolution, composition and display maths."""
