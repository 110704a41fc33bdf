"""The Sobolev kernel K_gd on the sphere: interpolation (Cholesky + near/far fast
summation), the band-limited kernel, and their numba hot loops.
"""
