"""``python -m app.cli``: the same as the ``shapesearch`` command."""

from app.cli import main

raise SystemExit(main())
