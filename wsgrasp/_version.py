"""The package version (read by every layer without importing the root package)."""

__version__ = "0.1.0"
