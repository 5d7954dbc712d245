"""Report plots (matplotlib, Agg): a job's runs (``run``), its estimates against the truth
(``estimation``), plans (``plan``) and the pieces they share (``draw``)."""
