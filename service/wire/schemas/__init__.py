"""Request and response models, one module per capability; common.py holds the shared pieces."""
