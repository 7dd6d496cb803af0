"""Shared helpers for the test-suite."""

import math

import numpy as np


def fitted_order(h, err):
    """Least-squares slope of log|err| against log h (the measured order)."""
    h = np.asarray(h, dtype=float)
    e = np.abs(np.asarray(err, dtype=float))
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def paper_sec2a(eta):
    """Sec. II A closed forms (frictionless granule 1, kinetic friction eta on granule 2)."""
    v1 = -eta * math.pi / (2 * math.sqrt(2))
    v2 = math.sqrt(1 - eta * eta) + v1
    return v1, v2, (v1 * v1 + v2 * v2)  # E/E0 = (v1^2 + v2^2)/2 / (1/2)
