"""Sparse KKT stepping (placeholder docstring, replaced below)."""
