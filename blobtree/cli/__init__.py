"""The ``blobtree`` command line."""
