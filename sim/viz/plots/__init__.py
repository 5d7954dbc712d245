"""Report plots of runs and plans (matplotlib, Agg)."""
