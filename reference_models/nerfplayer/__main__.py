"""``python -m reference_models.nerfplayer train|render ...`` (see ``reference_models.common.cli``)."""

import sys

from reference_models.common.cli import main
from reference_models.nerfplayer.field import SPEC

if __name__ == "__main__":
    sys.exit(main(SPEC))
