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
# # Tutorial 3 — registration: the panorama and the laser scan (Appendix A)
#
# Torres-Méndez & Dudek (IJCV 2008), Appendix A, Eqs. 14–21.
#
# Range synthesis needs an intensity image and a partial range image *on the
# same grid*. The robot has neither: its camera takes a picture every 18°
# while the pan unit turns, and its laser returns spherical samples
# `(r, θ, φ)` from a centre a few centimetres below the camera's. Appendix A
# registers the two without calibration:
#
# 1. project every picture onto a cylinder of radius `f` (**Eq. 14**), where
#    panning is a translation;
# 2. find the translation between neighbouring pictures by Gauss–Newton on
#    their intensity difference (**Eqs. 15–17**) and blend them with a hat
#    weight (**Eq. 18**) into a panorama;
# 3. put the laser samples on a cylinder of the same radius (**Eq. 19**);
# 4. fit a global warp from the range image to the panorama (**Eq. 21**, an
#    approximation of **Eq. 20**), then stretch the range locally until its
#    depth edges lie on the intensity edges.
#
# Everything runs on a synthetic rig with ground truth
# (`refsynth.scenes.rig`): f = 300 px, ΔY = 5 cm, walls 5–8 m away.
#
# **Before this tutorial**: tutorial 0 (a registered intensity and partial
# range are what synthesis needs); a pinhole camera (a point `(x, y, z)`
# lands at `(f x / z, f y / z)`); least squares with numpy.
#
# **After it** you can project a picture onto a cylinder (Eq. 14), find the
# translation between two overlapping pictures by Gauss–Newton (Eqs. 15–17)
# and watch it converge, blend pictures into a mosaic (Eq. 18), put laser
# samples on the same cylinder (Eq. 19), fit the global warp (Eq. 21) and
# the local stretch, and score each stage against ground truth.
#
# Open this file as a notebook, build it with
# `python -m refsynth notebooks --out notebooks --only 03`, or run it as
# plain Python (`python tutorials/03_registration.py`; figures in
# `tutorial-output/`).

# %%
import matplotlib.pyplot as plt
import numpy as np
from _course import OUT, save

import refsynth
from refsynth.registration import (
    Warp,
    align_global,
    align_translation,
    cylindrical_warp,
    gauss_newton_step,
    hat_weights,
    intensity_edges,
    mosaic,
    mosaic_position,
    range_edges,
    refine_local,
    register,
    registration_errors,
    resample_range,
    scan_to_cylinder,
    warp_forward,
)
from refsynth.scenes import laser_scan, render_views, rig_room

# %% [markdown]
# ## 1. The rig's pictures
#
# Seven pictures, every 18° (nominally: each pan angle is off by up to 0.4°),
# each jittered vertically by up to 1.5 px, darkened towards its corners by
# vignetting (cos⁴), with noise. Neighbours overlap by 20 %.

# %%
room = rig_room(2)
views = render_views(room, n_views=7, start_angle=-np.radians(54), height=200, seed=2)
focal = views.focal
print(f"{len(views.images)} views of {views.images.shape[2]}x{views.images.shape[1]} px, "
      f"f = {focal:.0f} px; true steps {np.round(views.translations[:, 0], 2).tolist()} px "
      f"(nominal {focal * np.radians(18):.2f})")

fig, axes = plt.subplots(1, len(views.images), figsize=(13, 3.2))
for k, (ax, view) in enumerate(zip(axes, views.images)):
    ax.imshow(view, cmap="gray", vmin=0, vmax=1)
    ax.set_title(f"{np.degrees(views.pan_angles[k]):.0f}°")
    ax.set_axis_off()
save(fig, "03_views.png", dpi=90)

# %% [markdown]
# ## 2. Eq. 14: onto the cylinder
#
# $$\psi = \arctan\frac{x}{z}, \qquad v = f\,\frac{y}{\sqrt{x^2 + z^2}}$$
#
# A pixel `(x, y)` of a picture is the ray `(x, y, f)`; on the cylinder of
# radius `f`, unrolled, it lands at `(f ψ, v)`. `cylindrical_warp` maps back
# from every cylinder pixel (inverse mapping, bilinear interpolation). Straight
# lines bend, the picture's sides shrink, and the valid region becomes a
# barrel (NaN outside).

# %%
cylinders = [cylindrical_warp(view, focal) for view in views.images]
fig, axes = plt.subplots(1, 2, figsize=(6, 4))
axes[0].imshow(views.images[3], cmap="gray", vmin=0, vmax=1)
axes[0].set_title("perspective")
axes[1].imshow(cylinders[3], cmap="gray", vmin=0, vmax=1)
axes[1].set_title("cylindrical (Eq. 14)")
for ax in axes:
    ax.set_axis_off()
save(fig, "03_cylindrical.png", dpi=90)

# %% [markdown]
# ## 3. Eqs. 15–17: the translation between neighbours
#
# With `x'_i = x_i + t`, linearise the error of Eq. 15 (Eq. 16) and solve
#
# $$\Big(\sum_i g_i g_i^\top\Big)\,\delta t = -\sum_i e_i g_i \qquad \text{(Eq. 17)}$$
#
# over the overlap, `e_i = I1(x'_i) − I0(x_i)`, `g_i = ∇I1(x'_i)`; repeat
# from the known pan step until `δt` is tiny. Here are the first steps,
# taken by hand with `gauss_newton_step` on the finest level.

# %%
reference, moving = cylinders[2], cylinders[3]
t = np.array([focal * (views.pan_angles[3] - views.pan_angles[2]), 0.0])
truth = views.translations[2]
trace = [np.hypot(*(t - truth))]
for _ in range(6):
    t = t + gauss_newton_step(reference, moving, t)
    trace.append(np.hypot(*(t - truth)))
print("Eq. 17 steps, distance to the truth (px): "
      + ", ".join(f"{d:.3f}" for d in trace))
found = align_translation(reference, moving, (focal * np.radians(18), 0.0))
print(f"align_translation: t = ({found[0]:.3f}, {found[1]:.3f}), truth ({truth[0]:.3f}, "
      f"{truth[1]:.3f}), {np.hypot(*(found - truth)):.3f} px off")
for photometric in (False, True):
    pair_errors = [np.hypot(*(align_translation(cylinders[k], cylinders[k + 1],
                                                (focal * np.radians(18), 0.0),
                                                photometric=photometric)
                              - views.translations[k])) for k in range(len(cylinders) - 1)]
    print(f"over the {len(pair_errors)} pairs, photometric={photometric}: RMS error "
          f"{np.sqrt(np.mean(np.square(pair_errors))):.3f} px, worst {max(pair_errors):.3f} px")

# %% [markdown]
# The plain steps converge in three or four iterations, but not to the truth:
# they stop a fraction of a pixel off. The pictures are darker towards their
# corners (vignetting), so in the overlap the same wall is brighter in one
# picture than in the other, and Eq. 15 reads part of that difference as a
# shift. `align_translation` adds what a real rig needs (see its docstring):
# a whole-pixel search around the start, coarse-to-fine blur levels, and a
# gain varying linearly across the overlap that absorbs vignetting — the
# *photometric* terms. On a single pair the two can come out close (compare
# the first lines); over all the pairs of this rig the photometric terms
# give the lower RMS error, as the last two lines show.
#
# ## 4. Eq. 18: blending
#
# $$w(x, y) = \Big(1 - \frac{|x - w/2|}{w/2}\Big)\Big(1 - \frac{|y - h/2|}{h/2}\Big)$$
#
# Each picture weighs its pixels by their distance to its edge; where two
# overlap, the mosaic is the weighted mean, so the vignetting fades across
# the seam instead of stepping.

# %%
pano = mosaic(views.images, focal, np.diff(views.pan_angles), start_angle=views.pan_angles[0])
errors = pano.translations - views.translations
print(f"mosaic {pano.image.shape[1]}x{pano.image.shape[0]} px; translation error RMS "
      f"{np.sqrt(np.mean(np.sum(errors ** 2, axis=1))):.3f} px over {len(errors)} pairs")

fig, axes = plt.subplots(2, 1, figsize=(12, 5.2), gridspec_kw={"height_ratios": [3, 1.2]})
axes[0].imshow(pano.image, cmap="gray", vmin=0, vmax=1)
axes[0].set_title("the cylindrical mosaic (Eqs. 14–18)")
axes[1].imshow(pano.weight, cmap="magma")
axes[1].set_title("Σ of the hat weights (Eq. 18)")
for ax in axes:
    ax.set_axis_off()
save(fig, "03_mosaic.png", dpi=90)
inset = hat_weights((5, 7))
print(f"Eq. 18 on a 5x7 picture: centre {inset[2, 3]:.3f}, corner {inset[0, 0]:.3f}")

# %% [markdown]
# ## 5. Eq. 19: the laser on the cylinder
#
# $$P(r, \theta, \phi) \to P\Big(r, \phi, \frac{f}{\tan\theta}\Big) \to P(r, \phi, h)$$
#
# The laser sweeps vertical slices every 0.36°; this scan keeps 10 slices
# out of every 25 (40 %, the paper scans 30–50 %). On a cylinder of radius
# `f` with rows one pixel of height apart, each slice is a column.

# %%
scan = laser_scan(room, phi_range=(-1.15, 1.15), seed=2)
height = pano.image.shape[0]
cylinder = scan_to_cylinder(scan.r, scan.theta, scan.phi, focal,
                            h_range=(pano.horizon_row - height - 4, pano.horizon_row + 4))
found_edges = range_edges(cylinder)
print(f"cylindrical range image {cylinder.range.shape[1]} slices x {cylinder.range.shape[0]} "
      f"rows, {np.isfinite(cylinder.range).mean():.0%} measured, "
      f"{found_edges.phi.size} depth-edge points")

fig, ax = plt.subplots(figsize=(10, 3))
im = ax.imshow(cylinder.range, cmap="viridis", aspect=0.5)
ax.set_title("the partial scan on the cylinder (Eq. 19): columns = slices, NaN = white")
fig.colorbar(im, ax=ax, fraction=0.02, label="r (m)")
save(fig, "03_scan_cylinder.png", dpi=90)

# %% [markdown]
# ## 6. Eq. 21: the global warp
#
# $$u = a\phi + \alpha, \qquad v = b h + \beta$$
#
# The exact relation (Eq. 20) has `v = b h + v_0 + f ΔY / ρ`: the offset
# between laser and camera makes near things look lower to the laser. Eq. 21
# takes it as one constant β. The rig's nominal geometry (`a = f`, `b = −1`,
# the laser's azimuth 0 at the camera's pan 0) is the paper's "initial
# estimate"; `align_global` moves α, β to where the depth edges best meet the
# intensity edges (a chamfer search, then least squares on edge matches).

# %%
edges = intensity_edges(pano.image)
nominal = Warp(focal, -1.0, float(pano.column_of(0.0)), pano.horizon_row)
warp, info = align_global(pano.image, cylinder, nominal, edges=edges, fit_scale=False)
print(f"nominal warp {tuple(round(p, 2) for p in nominal)}")
print(f"global warp  {tuple(round(p, 2) for p in warp)} (chamfer shift {info['shift']})")

# %% [markdown]
# The nominal warp is the rig's design; the global warp moves α and β by
# the printed chamfer shift (a few pixels, as the paper's 5–7 px of initial
# misalignment lead one to expect), and leaves `a = f` and `b = −1`, which
# follow from both cylinders having radius `f`.
#
# ## 7. The local stretch
#
# Depth edges (range discontinuities) are matched, segment by segment, to
# intensity edges of the same orientation; where a segment is off by more
# than half a sample, its offset becomes a control point; the offsets are
# interpolated cubically between control points into a displacement field,
# and the range is resampled through it. Repeat until nothing is off.

# %%
displacement, history = refine_local(pano.image, cylinder, warp, edges=edges)
print("local stretch, mean misalignment of the matched edges (px): "
      + " → ".join(f"{h['misalignment']:.2f}" for h in history))
print(f"control points per pass: {[h['controls'] for h in history]}; largest displacement "
      f"{np.abs(displacement).max():.2f} px")

positions = {
    "nominal": warp_forward(nominal, None, found_edges.phi, found_edges.h),
    "Eq. 21": warp_forward(warp, None, found_edges.phi, found_edges.h),
    "Eq. 21 + stretch": warp_forward(warp, displacement, found_edges.phi, found_edges.h),
}
fig, axes = plt.subplots(1, 3, figsize=(13, 4))
window = np.argmax(found_edges.axis == 1)  # around the first horizontal depth edge
centre = positions["Eq. 21"][window]
for ax, (name, where) in zip(axes, positions.items()):
    ax.imshow(pano.image, cmap="gray", vmin=0, vmax=1)
    ys, xs = np.nonzero(edges[0])
    ax.plot(xs, ys, ",", color="gold")
    ax.plot(where[:, 0], where[:, 1], ".", color="red", ms=4)
    ax.set_xlim(centre[0] - 60, centre[0] + 60)
    ax.set_ylim(centre[1] + 40, centre[1] - 40)
    ax.set_title(f"depth edges (red), {name}")
    ax.set_axis_off()
save(fig, "03_edges_alignment.png", dpi=90)

# %% [markdown]
# The rig knows the truth, so we can score each stage: for every depth edge,
# the error along its normal between where the registration puts its near
# sample and where that 3-D point appears in the mosaic.

# %%
registration = register(
    views.images, views.pan_angles, focal, (scan.r, scan.theta, scan.phi)
)
scores = registration_errors(registration, scan, views)
for stage in ("nominal", "global", "local"):
    score = scores[stage]
    print(f"edge misalignment, {stage:>7}: mean {score['mean']:.2f} px "
          f"(vertical edges {score['mean_u']:.2f}, horizontal {score['mean_v']:.2f})")
true_positions = mosaic_position(scan.points[::25, ::40].reshape(-1, 3), pano, views)
print(f"(ground truth from the rig: e.g. {len(true_positions)} points placed on the mosaic)")
gain = scores["global"]["mean"] - scores["local"]["mean"]
print(f"the global warp removes {scores['nominal']['mean'] - scores['global']['mean']:.2f} px "
      f"of misalignment, the local stretch {gain:.2f} px")

# %% [markdown]
# Read the two stages apart. The global warp does nearly all the work: from
# several pixels (the paper reports 5–7 px for its initial estimate) to
# under one. The stretch only moves range where a whole segment of depth
# edge is matched and consistently off; when the control-point count above
# is zero, as it can be, no segment qualified and the stretch leaves the
# range as the global warp put it. The registration benchmark (the
# documentation's *Registration* guide) runs eight rigs: there the stretch
# helps, by a few hundredths of a pixel on average, mostly on horizontal
# edges (the tops of furniture, whose parallax Eq. 21's single β cannot
# fit; exercise 3).
#
# ## 8. Registered intensity and range, ready for synthesis
#
# `register_scan` (or `register`) does all of the above and crops both
# images to the rectangle the mosaic covers fully: the input of
# `refsynth.synthesize`. We fill a window of it with NP.

# %%
intensity, partial = registration.intensity, registration.partial_range
print(f"registered pair {intensity.shape[1]}x{intensity.shape[0]} px, "
      f"{np.isfinite(partial).mean():.0%} with range")
rows, cols = slice(40, 104), slice(400, 496)
result = refsynth.synthesize(intensity[rows, cols], partial[rows, cols], seed=0)
full = resample_range(cylinder, registration.warp, pano.weight.shape, registration.displacement)
print(f"NP filled {len(result.order)} pixels of a {result.range.shape[1]}x"
      f"{result.range.shape[0]} window; range {result.range.min():.2f}–"
      f"{result.range.max():.2f} m")

fig = plt.figure(figsize=(12, 8))
top = fig.add_subplot(3, 1, 1)
top.imshow(intensity, cmap="gray", vmin=0, vmax=1)
top.add_patch(plt.Rectangle((cols.start, rows.start), 96, 64, fill=False, color="red"))
top.set_title("registered intensity (the cropped mosaic); the window in red")
middle = fig.add_subplot(3, 1, 2)
middle.imshow(partial, cmap="viridis", vmin=1, vmax=9)
middle.set_title("registered partial range (NaN = white)")
for k, (image, title, cmap) in enumerate([
    (intensity[rows, cols], "window: intensity", "gray"),
    (partial[rows, cols], "window: partial range", "viridis"),
    (result.range, "window: NP-synthesized range", "viridis"),
]):
    ax = fig.add_subplot(3, 3, 7 + k)
    ax.imshow(image, cmap=cmap, **({"vmin": 0, "vmax": 1} if cmap == "gray" else {}))
    ax.set_title(title)
for ax in fig.axes:
    ax.set_axis_off()
save(fig, "03_registered.png", dpi=90)
print(f"figures written to {OUT}/ ({full.shape[1]}x{full.shape[0]} px range on the mosaic)")

# %% [markdown]
# ## Exercises
#
# Solutions: `tutorials/solutions/03_registration.py` (the test suite runs
# it).
#
# 1. **Implement Eq. 17 yourself.** Sample `I1` and its central-difference
#    gradient bilinearly at `x_i + t` (`scipy.ndimage.map_coordinates`), form
#    `Σ g gᵀ` and `−Σ e g` over the overlap and solve. Compare your first step
#    with `refsynth.registration.gauss_newton_step` on two views of a smooth
#    pattern with a known sub-pixel shift, and iterate both to convergence.
# 2. **Eq. 21 from noisy correspondences.** Draw `(φ, h)` points, map them
#    with a known warp, add 1 px of noise and fit with
#    `refsynth.registration.fit_warp`. How does the error of α and β fall with
#    the number of correspondences (2, 8, 32, 128)? Why are two points so bad?
# 3. **How wrong is one β?** Compute Eq. 20's parallax `f ΔY / r` for the
#    rig's nearest furniture (1.5 m) and farthest wall (8 m), and its spread
#    over the samples of `laser_scan(rig_room(2), ...)`
#    (`refsynth.scenes.FOCAL`, `refsynth.scenes.DELTA_Y`). What does that say
#    about Eq. 21's constant β?
