"""``python -m slbasis ...``: the same as the ``slbasis`` command."""

from slbasis.cli import main

raise SystemExit(main())
