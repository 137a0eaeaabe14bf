"""Generated numeric kernels, one module per catalogue family (see slbasis.codegen)."""
