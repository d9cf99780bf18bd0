"""python -m pipeline: the same as the console script floe-impact (pipeline.console)."""
from .console import console

console()
