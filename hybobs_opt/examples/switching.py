"""Placeholder: filled in by the example work for this paper."""
