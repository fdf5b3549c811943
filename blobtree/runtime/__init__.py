"""The runtime under the kernels: numba compilation and its cache (``jit``), kernels on all
cores (``threads``) and glibc's thresholds for large blocks (``allocator``)."""
