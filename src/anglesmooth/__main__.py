"""``python -m anglesmooth``: the same command line as the ``anglesmooth`` script."""

from .cli import main

if __name__ == "__main__":  # pragma: no cover - exercised in a subprocess
    main()
