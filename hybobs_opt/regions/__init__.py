"""Observability regions of PWA systems from LP feasibility tests (paper 002, Sections 2-3)."""
