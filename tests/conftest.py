"""Test-suite configuration.

Hypothesis profiles: ``make test`` (and so CI) runs with ``HYPOTHESIS_PROFILE=ci``, which
derandomises the property tests so that a submission's CI result does not depend on the
examples drawn that day; a plain ``pytest`` explores new random examples (that is how
the (-oo, b) interval bug of ``slbasis.symbolic.verify`` was found).
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
