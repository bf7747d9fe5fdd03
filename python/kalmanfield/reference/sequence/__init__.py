"""Twins of the sequence filters (method page *Sequence filter*, §2.5)."""
