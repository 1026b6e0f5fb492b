"""``python -m omniloc``: the command line, as the ``omniloc`` script (:mod:`omniloc.cli`)."""

from omniloc.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
