"""Spherical-harmonic export for engines: coefficients, formats, ringing, reports."""
