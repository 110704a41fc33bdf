"""Environment maps: lat-long geometry, the EnvMap type and its file I/O, value scales,
image metrics, library map sources, the built-in map.
"""
