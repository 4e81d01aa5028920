"""``python -m oclshade``: the same command line as the ``oclshade`` script."""
from .cli import main

raise SystemExit(main())
