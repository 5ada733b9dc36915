"""The impact laws, one module each: the law's definition and its exact kernels."""
