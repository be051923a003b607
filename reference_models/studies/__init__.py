"""Studies that generate tables in docs/ from the synthetic scenes (rerun with one command each)."""
