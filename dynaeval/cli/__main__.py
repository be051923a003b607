"""``python -m dynaeval.cli``: the ``dynaeval`` command."""

import sys

from dynaeval.cli import main

sys.exit(main())
