"""Hostile inputs: the property-based fuzz suite and the reproducible corpus."""
