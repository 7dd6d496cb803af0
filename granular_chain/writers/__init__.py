"""Writers: what a run leaves on disk. They see only a Result (and the scene as metadata).

summary.py     summary.json (always written by ``granular-chain run``)
trajectory.py  trajectory.h5: t, x, v, f, energy ledger, events (read back by :mod:`..readback`)
tables.py      energy.csv and events.csv
vtk.py         run.pvd + vtk/frame_NNNNNN.vtp, a VTK time series for ParaView and pyvista
plots.py       PNGs: space-time diagram, energy ledger, granule velocities, a rendered frame

Heavy libraries (h5py, pyvista, matplotlib) are imported only by the writer that needs
them, so a run that asks for no writer does not load them. See docs/writers.md.
"""
