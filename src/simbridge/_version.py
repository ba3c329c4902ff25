"""simbridge's version, in a module of its own so that a module of the package can read it
without importing the package's ``__init__`` (which imports that module: a circle)."""

__version__ = "0.1.0"
