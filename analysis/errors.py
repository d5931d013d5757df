"""Errors the command line reports as one line."""


class UsageError(Exception):
    """Bad input detected after parsing; reported as one line and a non-zero exit."""
