"""``python -m humanoid_ik``."""

import sys

from humanoid_ik.cli import main

sys.exit(main())
