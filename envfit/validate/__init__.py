"""Predicted against measured shading errors on a map (the paper's Figs. 7-8) and the
report that states them.
"""
