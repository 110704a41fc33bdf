"""Libraries of maps: one factorisation per (s, N) for all maps, tasks, local and dask
executors, the driver loop and the library report.
"""
