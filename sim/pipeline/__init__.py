"""The plan -> trajectory -> track pipeline: cases, simulate jobs, the sweep over every case."""
