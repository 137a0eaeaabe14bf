"""``python -m hdpbsid ...``: the same as the ``hdpbsid`` command."""

from hdpbsid.cli import main

raise SystemExit(main())
