"""``python -m dynaeval`` and the ``dynaeval`` command (``[project.scripts]``): the command line,
loaded inside a guard, so Ctrl-C while its modules load (~0.3 s) is exit 130 with one line, not
a traceback (issue 43)."""

import sys


def main() -> int:
    """Load the command line and run it; the exit code."""
    try:
        from dynaeval.cli import main as cli_main
    except KeyboardInterrupt:
        print("dynaeval: interrupted while starting; nothing done", file=sys.stderr)
        return 130
    return cli_main()


if __name__ == "__main__":
    sys.exit(main())
