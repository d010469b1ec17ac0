"""``python -m pincal`` and the ``pincal`` console script: a start that imports nothing heavy before it can
answer a Ctrl-C with one line."""

from __future__ import annotations

import sys


def main() -> int:
    """Run the command line (:func:`pincal.cli.app.main`); an interrupt at any point ends with exit code 130."""
    try:
        from pincal.cli.app import main as run

        return run()
    except KeyboardInterrupt:
        print("pincal: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
