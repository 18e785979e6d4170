"""Transport velocities: particles advected with a velocity other than their momentum
velocity (one paper per file)."""
