"""``python -m linkage_ros.bench ...``: the same as ``linkage bench ...``."""

import sys

from .command import main

sys.exit(main())
