"""What a person sees: plots of runs and fitness, and videos of drives (never imported by the physics)."""
