"""Measurement statistics: adaptive RMSE over axes, bootstrap intervals, axis proposal."""
