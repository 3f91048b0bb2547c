"""The teaching station's defaults, read by the command line and the app alike.

A leaf module: ``lfd-track teach --help`` shows them without importing the web stack, and the
app uses the same values without importing the command line.
"""

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
DEFAULT_FPS = 10.0
"""[frames/s] rate at which the camera view is pushed to each page."""
