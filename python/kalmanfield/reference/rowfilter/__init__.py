"""Twins of the row filters."""
