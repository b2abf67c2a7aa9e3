"""Utilities every layer may use (the compiled kernels' ``njit``, the nearest names of
a mistyped one): they import nothing of the package, so no layer reaches another
through them.
"""
