"""Time steppers: velocity-Verlet (fixed dt) and event stepping."""
