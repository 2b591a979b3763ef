"""Runtime observers with one contract: ``reset(...)``, ``step(u, y) -> Estimate``, ``run(U, Y)``."""
