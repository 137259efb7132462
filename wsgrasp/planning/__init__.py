"""Candidate generation, batched evaluation, rejection reasons, search."""
