"""``python -m slbasis.kernels [FAMILY ...]``: regenerate the generated kernel modules."""

import sys

from slbasis.codegen import main

raise SystemExit(main(sys.argv[1:]))
