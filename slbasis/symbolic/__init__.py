"""Exact (sympy) derivations for Sturm–Liouville eigenproblems."""
