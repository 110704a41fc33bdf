"""The smoothness s of a map: the fit criteria and search (fit.smoothness) and the
paper's Table 2 (fit.table2).
"""
