"""``python -m linkage_ros.cli ...``: the same as ``linkage ...``."""

import sys

from .parser import main

sys.exit(main())
