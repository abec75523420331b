"""Studies: grids of runs, their records, executors and summaries."""
