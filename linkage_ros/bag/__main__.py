"""``python -m linkage_ros.bag ...``: the same as ``linkage bag ...``."""

import sys

from .command import main

sys.exit(main())
