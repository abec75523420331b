"""Matplotlib figures (Agg backend), one module per subject."""

import matplotlib

matplotlib.use("Agg")
