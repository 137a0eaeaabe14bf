"""slbasis: orthonormal bases from Sturm–Liouville eigenproblems, derived and verified."""

__all__: list[str] = []
