"""Plumbing, each helper once: shipped data lookup, progress bars, signal handling."""
