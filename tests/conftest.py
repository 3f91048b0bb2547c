"""Makes the helpers the test folders share (``lfd_test_support``, ``parser_property_support``)
importable from any folder: the folders are not packages, and each test module sits in the folder
of the subpackage it tests (``tests/package/`` for the package as a whole)."""

import sys
from pathlib import Path

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)
