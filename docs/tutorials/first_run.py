"""First run: run a scene from the command line, then open what it wrote.

Runs scenarios/chain_striker.yaml (a striker on 99 Hertz granules) for 40 time
units with the VTK series on, lists the run folder, opens trajectory.h5 with
xarray and renders one VTK frame off screen with pyvista (no display needed).
"""

import subprocess
import sys
from pathlib import Path

import pyvista as pv
import xarray as xr

pv.OFF_SCREEN = True
SCENE = Path(__file__).resolve().parents[2] / "scenarios" / "chain_striker.yaml"

# The same as: granular-chain run scenarios/chain_striker.yaml --set run.t_end=40 --set output.every=40 --vtk --out run
subprocess.run([sys.executable, "-m", "granular_chain", "run", str(SCENE),
                "--set", "run.t_end=40", "--set", "output.every=40",
                "--vtk", "--out", "run", "--quiet"], check=True)

print("run/")
for path in sorted(Path("run").iterdir()):
    if path.is_dir():
        print(f"  {path.name}/  ({len(list(path.iterdir()))} files)")
    else:
        print(f"  {path.name:<16s} {path.stat().st_size:>9,d} bytes")

ds = xr.open_dataset("run/trajectory.h5", engine="h5netcdf")
print("\ntrajectory.h5 through xarray:")
print(f"  dimensions {dict(ds.sizes)}")
for name, var in ds.data_vars.items():
    units = var.attrs.get("units", "")
    meaning = var.attrs.get("long_name", "").split(" (scaled")[0][:60]
    print(f"  {name:<18s} {str(var.dims):<20s} {units:<3s} {meaning}")
v = ds["v"]
t_peak = float(v.isel(granule=20).idxmax("time"))
print(f"\ngranule 20 peaks at t = {t_peak:.2f} with v = {float(v.isel(granule=20).max()):.4f}")

reader = pv.get_reader("run/run.pvd")
reader.set_active_time_value(reader.time_values[-1])
frame = reader.read()[0]
print(f"VTK frame at t = {reader.time_values[-1]:g}: {frame.n_points} granules, "
      f"point data {list(frame.point_data.keys())}")
# a unit sphere scaled by each granule's radius (point data "radius")
spheres = frame.glyph(geom=pv.Sphere(radius=1.0, theta_resolution=16, phi_resolution=16),
                      orient=False, scale="radius")
plotter = pv.Plotter(off_screen=True, window_size=(1000, 260))
plotter.add_mesh(spheres, scalars="velocity", cmap="RdBu_r", clim=(-0.7, 0.7),
                 scalar_bar_args={"title": "velocity"})
plotter.view_xy()
plotter.camera.zoom(1.6)
plotter.camera.focal_point = (float(frame.points[40, 0]), 0, 0)
plotter.camera.position = (float(frame.points[40, 0]), 0, 60)
plotter.screenshot("frame.png")
