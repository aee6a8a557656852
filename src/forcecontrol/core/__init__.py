"""The package's own small tools: input checks, small dense linear algebra for the compiled
kernels, the names of task axes, JSON without NaN, lazy imports and the compiled-kernel cache.

Nothing here knows about robots or control; everything above may import it.
"""
