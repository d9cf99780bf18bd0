"""How the kernels compile, apart from what they compute: ``@kernel`` (jit.py: linked IR inside,
whole program at the top), the on-disk cache keyed by the solver's source (kernel_cache.py),
and the first compile in two processes (parallel_compile.py)."""
