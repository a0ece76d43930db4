#: The package version (also the version recorded in datasets and checkpoints).
__version__ = "0.1.0"
