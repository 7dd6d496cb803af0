"""Errors shared by the stages of a run."""

__all__ = ["SimulationError"]


class SimulationError(ValueError):
    """A run refused before it started (with the field to change and the limit)."""
