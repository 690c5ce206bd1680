"""The NvCloth-style position-based solver: model, state, stages and kernels."""
