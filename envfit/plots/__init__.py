"""Figures (PNG, matplotlib's Agg backend), one module per experiment."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg", force=False)
