"""Shading integrals on a map: the ground truth, the estimators (quadrature, SH/HSH
truncation) and the spectra (per-degree map and rule power, lookup transfer).
map_sampler: the map's importance-sampling distribution (luminance × solid angle, smoothed, floored).
importance: the renderer estimators — map importance sampling, BRDF sampling and their MIS.
is_variance: the exact variance / RMSE of those random-point estimators (IS, MIS), from the map.
sphere_quadrature: the quadrature over the sphere behind is_variance (lobe-cut cells, exact horizon).
sources: bright-source detection (sun, lamps) and the exact source / rest split of those estimators.
measurement: bootstrap (BCa) confidence intervals of the RMSE over axes, adaptive axis counts, prediction agreement.
"""
