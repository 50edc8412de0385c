"""``python -m pelcs``: the same command as ``pelcs``."""

from pelcs.cli import main

raise SystemExit(main())
