"""Where the cases run: the session, the dask engine, the workers, batch systems (SLURM, PBS), the
forkserver that forks the local workers ready. Imports only the stages before it (common, study,
store)."""
