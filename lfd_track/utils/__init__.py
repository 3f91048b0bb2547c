"""Plumbing every part of lfd-track shares, each helper once: atomic writes, regular-file reads,
output names and checks, staging and locks, shipped data lookup, extras, progress bars, signals."""
