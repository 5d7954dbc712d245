"""Tools built on the pipeline: gain tuning, the regression suite, benchmarks."""
