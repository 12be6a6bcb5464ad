"""``python -m sassi_bench`` runs the command line."""

import sys

from sassi_bench.commands import main

sys.exit(main())
