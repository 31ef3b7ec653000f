"""``python -m grouptron`` (e.g. ``torchrun --nproc_per_node 2 -m grouptron train ...``)."""

import sys

from grouptron.cli import main

sys.exit(main())
