"""floe-impact study runner."""
