"""``python -m nh_operators ...`` runs the ``nh-operators`` command (also under torchrun)."""

import sys

from .cli import main

sys.exit(main())
