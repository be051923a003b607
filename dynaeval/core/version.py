"""dynaeval's version, as every results file, prepared folder, suite record and leaderboard
records it (and ``dynaeval --version`` prints); the package root hands it on as
``dynaeval.__version__``."""

VERSION = "0.1.0"
