"""The advisor: smallest N per rule and smallest SH/HSH degree for a target error,
with its on-disk cache.
"""
