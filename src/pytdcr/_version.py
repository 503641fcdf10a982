"""The package's version, defined once (every manifest and record names it)."""

__version__ = "0.1.0"
