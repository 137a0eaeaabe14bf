"""hdpbsid: continuous-time predictor-based subspace identification in a basis domain."""

__all__: list[str] = []
