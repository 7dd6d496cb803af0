"""Small compiled scalar laws (contact and friction) from which the kernels are built."""
