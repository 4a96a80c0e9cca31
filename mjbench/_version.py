"""The package's version (the distribution's is read by ``mjbench --version``)."""
__version__ = "0.1.0"
