"""Physical sizes more than one world module needs (a leaf module: one owner each)."""

ROVER_BODY_WIDTH_M = 0.225
"""[m] the default rover's outer width across both treads; a track narrower cannot be driven."""
