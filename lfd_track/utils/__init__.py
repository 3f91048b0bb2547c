"""Plumbing every part of lfd-track shares, each helper once."""
