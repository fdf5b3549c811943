"""blobtree: structured implicit surface modelling (the BlobTree)."""

__version__ = "0.1.0"
