"""Tests of each step kind, one module per kind (named as the kind)."""
