import sys

from dynaeval.cli import main

sys.exit(main())
