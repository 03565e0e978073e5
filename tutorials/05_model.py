# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Tutorial 5 — from range image to 3-D model
#
# Torres-Méndez & Dudek (IJCV 2008), §1 and Appendix A (Eqs. 14, 19).
#
# The paper divides 3-D environment modelling into three stages: "(1) sensor
# data acquisition and data registration; (2) depth inference or shape
# recovery; and (3) data integration for model representation". Tutorials
# 1–4 were the first two: after them a robot has, for each place it scanned
# from, a panorama and a *dense* range image — measured on 40 % of the
# columns, synthesized on the rest. This tutorial is stage 3,
# `refsynth.model`:
#
# 1. every pixel back to a 3-D point (the cylinder of Eqs. 14 and 19);
# 2. a mesh over the pixel grid that does not hang a curtain from a table to
#    the wall behind it;
# 3. several scan positions in one world frame, their odometry refined by
#    ICP and the overlap fused;
# 4. a PLY file and a rendered view.
#
# Everything runs on the rig's room (`refsynth.scenes.rig_room`), whose
# geometry is known, so each step can be checked against the truth.
#
# **Before this tutorial**: tutorial 2 (BP and its confidence) and tutorial 3
# (the cylindrical panorama, Eqs. 14 and 19); vectors, rotations about an
# axis, and what a triangle mesh is (vertices and index triples).
#
# **After it** you can turn a dense range image into 3-D points for a
# cylindrical or a pinhole camera and check the round trip, say which
# triangles of a range-image mesh the depth-discontinuity rule drops and
# why a step is never bridged, place scans from several poses in one frame,
# refine a pose by point-to-plane ICP and measure its error against the
# truth, fuse the overlap, and write and render the model.
#
# Open this file as a notebook, build it with
# `python -m refsynth notebooks --out notebooks --only 05`, or run it as
# plain Python (`python tutorials/05_model.py`); figures and the PLY go to
# `tutorial-output/` (or `$REFSYNTH_TUTORIAL_OUT`).

# %%
import math

import matplotlib.pyplot as plt
import numpy as np
from _course import OUT, save

import refsynth
from refsynth.model import (
    CylindricalCamera,
    Pose,
    alignment_error,
    build_model,
    merge_models,
    read_ply,
    refine_poses,
    write_ply,
)
from refsynth.plotting.model_view import draw_model, model_view_figure
from refsynth.registration import project_to_cylinder
from refsynth.scenes import cast_rays, rig_room

# %% [markdown]
# ## 1. Two scans of the room, and stage 2
#
# The rig turns through 360° at two places 1 m apart. At each, a cylindrical
# panorama of radius `f = 100` px: 628 columns (one pixel of arc, `1/f` rad,
# each) by 100 rows (one pixel of height). The range is ray-cast (with 5 mm
# of noise), the laser keeps 2 columns in every 5, and BP (§3.2.3) fills the
# rest. Its result carries a **confidence** per pixel: 1 where the range was
# measured, BP's belief of the chosen range elsewhere.

# %%
room = rig_room(0)
shape, focal = (100, 628), 100.0
camera = CylindricalCamera.panorama(focal, shape)  # column 0 at pan angle 0, 360°
true_poses = [Pose(), Pose(x=0.8, z=-0.6, heading=math.radians(25.0))]
rng = np.random.default_rng(0)
scans = []
for pose in true_poses:
    rays = camera.directions(shape) @ pose.matrix()[:3, :3].T  # the scanner's rays, world frame
    hits = cast_rays(room, rays, origin=pose.matrix()[:3, 3])
    intensity = np.clip(hits.albedo * hits.shading, 0.0, 1.0)
    known = np.broadcast_to(np.arange(shape[1]) % 5 < 2, shape)
    partial = np.where(known, hits.distance + rng.normal(0.0, 0.005, shape), np.nan)
    result = refsynth.synthesize(intensity, partial, method="bp", seed=0)
    scans.append(dict(truth=hits.distance, intensity=intensity, partial=partial,
                      result=result, measured=known))
    print(f"pose x = {pose.x} m, z = {pose.z} m, heading {math.degrees(pose.heading):.0f}°: "
          f"{known.mean():.0%} measured, BP median |error| "
          f"{np.median(np.abs(result.range - hits.distance)[~known]):.3f} m")

fig, axes = plt.subplots(4, 1, figsize=(10, 6), layout="constrained")
first = scans[0]
for ax, image, title, cmap in [
    (axes[0], first["intensity"], "intensity (the panorama)", "gray"),
    (axes[1], first["partial"], "measured range (m), 40 % of the columns", "viridis"),
    (axes[2], first["result"].range, "dense range after BP (m)", "viridis"),
    (axes[3], first["result"].confidence, "confidence (1 = measured)", "magma"),
]:
    ax.imshow(image, cmap=cmap)
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()
save(fig, "05_scan.png", dpi=90)

# %% [markdown]
# ## 2. Back-projection: Eqs. 14 and 19 backwards
#
# Column `j` is the pan angle `φ = (j − c_x) Δφ`, row `i` the height
# `h = (c_y − i) Δh` on the cylinder of radius `f` (Eq. 19: `h = f / tan θ`).
# The pixel's ray goes through `(f sin φ, h, f cos φ)`, and the range is the
# **Euclidean distance** from the centre (what the laser measures and
# `scan_to_cylinder` stores), so
#
# $$\mathbf{p} = \frac{r}{\sqrt{1 + (h/f)^2}}\Big(\sin\phi,\; \frac{h}{f},\; \cos\phi\Big).$$
#
# Projection (Eq. 14, `ψ = arctan(x/z)`, `v = f y / √(x² + z²)`, `r = |p|`)
# must give every pixel back.

# %%
r = first["result"].range
points = camera.back_project(r)
row, col, distance = camera.project(points, width=shape[1])
rows, cols = np.indices(shape)
print(f"back-projection then projection: max |Δrow| {np.abs(row - rows).max():.1e} px, "
      f"max |Δcol| {np.abs(col - cols).max():.1e} px, max |Δr|/r "
      f"{np.max(np.abs(distance - r) / r):.1e}")
psi, v = project_to_cylinder(points, focal)  # the registration stage's own Eq. 14
print(f"against refsynth.registration.project_to_cylinder: max |Δψ| "
      f"{np.abs(np.angle(np.exp(1j * (psi - camera.azimuth(cols))))).max():.1e} rad, "
      f"max |Δv| {np.abs(v - camera.height(rows)).max():.1e} px")

# %% [markdown]
# How good are the points? Against the room's true surface along each ray,
# for the measured pixels and, apart, for the synthesized ones (as a
# percentage of the range):

# %%
relative = np.abs(r - first["truth"]) / first["truth"]
known = first["measured"]
print(f"median distance to the true surface: measured {100 * np.median(relative[known]):.2f} %"
      f" of range, synthesized (BP) {100 * np.median(relative[~known]):.2f} %")

# %% [markdown]
# ## 3. The mesh, and the curtain
#
# Two triangles per 2×2 cell of pixels. Where a box stands in front of the
# wall, neighbouring pixels see surfaces metres apart, and a triangle between
# them is a *curtain* hanging from the box's edge to the wall. The rule
# (MVE's depth-map triangulation, with its footprint factor written as a
# fraction of range): an edge between neighbours `p`, `q` is a discontinuity
# when
#
# $$|r_p - r_q| > \tau\, L\, \min(r_p, r_q),$$
#
# `τ = max_jump` (0.05), `L` the edge's length in pixels (1, or √2 on the
# diagonal); a triangle with such an edge is dropped. A constant range keeps
# every triangle; a step larger than `τ` times the nearer range is never
# bridged.
#
# Which triangles span a *true* discontinuity? Those with an edge across
# which the room's true range jumps by more than 10 %: counted apart when
# all three vertices were measured and when one was synthesized.

# %%
truth = first["truth"].ravel()
measured = first["measured"].ravel()


def spans_true_jump(model):
    corners = model.pixels[model.faces][..., 0] * shape[1] + model.pixels[model.faces][..., 1]
    ranges = truth[corners]
    jump = ranges.max(axis=1) > 1.1 * ranges.min(axis=1)
    all_measured = measured[corners].all(axis=1)
    return int(np.sum(jump & all_measured)), int(np.sum(jump & ~all_measured))


models = {}
for label, max_jump in [("no rule (the curtain)", None), ("max_jump = 0.05", 0.05)]:
    model = build_model(r, camera, intensity=first["intensity"],
                        confidence=first["result"].confidence, measured=first["measured"],
                        max_jump=max_jump)
    edges = model.vertices[model.faces] - np.roll(model.vertices[model.faces], 1, axis=1)
    longest = np.linalg.norm(edges, axis=-1).max()
    on_measured, on_synthesized = spans_true_jump(model)
    print(f"{label}: {model.n_vertices} vertices, {model.n_faces} triangles; across a true "
          f"depth jump: {on_measured} measured, {on_synthesized} with a synthesized vertex; "
          f"longest edge {longest:.2f} m")
    models[label] = model

eye, target = np.array([-6.5, 7.0, -8.5]), np.array([0.0, -1.0, 0.0])
fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
for ax, (label, model) in zip(axes, models.items()):
    draw_model(ax, model, eye=eye, target=target, clip_above=0.3, title=label)
save(fig, "05_curtain.png", dpi=90)

# %% [markdown]
# With the rule, no triangle of measured points crosses a true jump, and the
# longest edge is a fraction of a metre instead of metres. The triangles that
# still cross one all have a synthesized vertex: BP put that pixel on the
# wrong side of a box's edge (on the box when it sees the wall, or the other
# way round), and the dense range runs smoothly across — so does the mesh,
# with no stretched triangle in it; that is stage 2's error, which no rule
# on the range can see. Far floor seen at a grazing angle loses triangles
# too: its range grows by more than 5 % per pixel there (raise `max_jump`,
# or scan at a higher resolution, to keep it).
#
# ## 4. Two poses in one frame
#
# A pose is where a scan was taken: the floor position `(x, z)`, the height
# `y`, and the heading about the vertical axis in the pan angles' sense
# (refsynth's frame: x right, y up, z forward). Odometry knows the second
# pose to within about 2° and 10 cm; point-to-plane ICP (on a
# `scipy.spatial.cKDTree`) aligns the second scan to the first.

# %%
scan_models = [build_model(s["result"].range, camera, intensity=s["intensity"],
                           confidence=s["result"].confidence, measured=s["measured"])
               for s in scans]
odometry = [Pose(), Pose(x=0.8 + 0.0707, z=-0.6 - 0.0707, heading=math.radians(27.0))]
refined, reports = refine_poses(scan_models, odometry)
for label, pose in [("odometry", odometry[1].matrix()), ("after ICP", refined[1])]:
    error = alignment_error(scan_models[1].vertices, pose, true_poses[1].matrix())
    print(f"{label}: median alignment error {100 * np.median(error):.2f} cm")
found = Pose.from_matrix(refined[1])
print(f"ICP: {reports[1].iterations} iterations, converged {reports[1].converged}; refined "
      f"pose x = {found.x:.4f} m, z = {found.z:.4f} m, heading "
      f"{math.degrees(found.heading):.3f}° (true: 0.8, -0.6, 25°)")

# %% [markdown]
# Merging puts both in the world frame and fuses the overlap: space is cut
# into cubes three point spacings wide, each cube goes to the scan whose
# point there is the most confident (ties: the nearer scanner), and the
# other scan's points and triangles in it go. One scan alone is never
# thinned.

# %%
world = merge_models(scan_models, refined)
both = sum(m.n_vertices for m in scan_models)
print(f"merged: {world.n_vertices} of {both} vertices ({both - world.n_vertices} fused away), "
      f"{world.n_faces} triangles, {int(world.synthesized.sum())} synthesized points")
path = write_ply(OUT / "05_room.ply", world)
back = read_ply(path)
exact = np.array_equal(back.vertices, world.vertices) and np.array_equal(back.faces, world.faces)
print(f"wrote {path.name}: {path.stat().st_size / 2**20:.1f} MB; read back exactly: {exact}")

# %% [markdown]
# ## 5. The rendered view
#
# An oblique view from above, the ceiling cut away at 0.3 m above the first
# scanner: once coloured by the registered intensity, once by confidence
# (yellow = measured).

# %%
fig = model_view_figure(world, colours=("intensity", "confidence"), eye=eye, target=target,
                        clip_above=0.3, title="two scan positions, merged (stage 3)")
save(fig, "05_model_view.png", dpi=90)
fig = model_view_figure(world, colours=("synthesized",), eye=eye, target=target,
                        clip_above=0.3, size=(6, 4.5))
save(fig, "05_measured_synthesized.png", dpi=90)
print("figures: " + ", ".join(sorted(p.name for p in OUT.glob("05_*.png"))))

# %% [markdown]
# ## Exercises
#
# Solutions: `tutorials/solutions/05_model.py` (the test suite runs it).
#
# 1. **Choosing τ.** Mesh the first scan's *true* range (plus 5 mm of noise)
#    with `grid_faces(r, max_jump=τ, wrap=True)` for τ = 0.01, 0.02, 0.05,
#    0.1, 0.2, 0.5 and None. For each, count the triangles, those across a
#    true jump of more than 10 %, and those on the floor (all three vertices
#    more than 1 m below the scanner). Which is the largest τ that bridges
#    no true jump, and how much of the floor does it keep?
# 2. **How wrong may odometry be?** Refine the second pose from odometry off
#    by 2°/10 cm, 5°/30 cm, 10°/50 cm, 20°/1 m and 30°/1.5 m (true ranges
#    plus 5 mm of noise). Where does ICP stop reaching 1 cm? Does
#    `IcpResult.converged` tell you when it went wrong?
# 3. **Depth from disparity.** Look at the room through Middlebury
#    Motorcycle's camera at a quarter of its size (f = 995 px, baseline
#    193 mm, doffs 31.1 px): turn the true depth into disparity, round it to
#    1/4 px as a stereo matcher might, and back to depth
#    (`disparity_to_depth`). How does the depth error grow with the depth,
#    and why (differentiate `z = f B / (d + doffs)`)?
