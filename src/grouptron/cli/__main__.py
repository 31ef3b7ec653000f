"""``python -m grouptron.cli``."""

import sys

from grouptron.cli.app import main

sys.exit(main())
