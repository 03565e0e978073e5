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
# # Tutorial 0 — the data: scenes, partial range, and how a fill is scored
#
# Torres-Méndez & Dudek (IJCV 2008), §3.1.1 (Fig. 2), §3.3 (Tables 1 and 4)
# and Eq. 13.
#
# **Before this tutorial** you should know numpy arrays, boolean masks and
# `NaN`, and how to show an array with matplotlib's `imshow`. Nothing about
# the paper.
#
# **After it** you can load the course's two scenes (a synthetic room with
# exact range, and the real Middlebury *Motorcycle*), cut a partial range out
# of a dense one with the paper's samplings, say how much of it is unknown,
# score a fill with the paper's error measure (Eq. 13) over the right pixels,
# and you know the bar every method in the later tutorials has to clear: the
# nearest-neighbour fill.
#
# The course: `pip install -e ".[course]"` in a refsynth checkout (it adds
# jupytext, nbclient, ipykernel and scikit-image, whose copy of the Motorcycle
# we use), then either open this file as a notebook (Jupyter with jupytext,
# JupyterLab, VS Code), build every tutorial as an executed notebook with
# `python -m refsynth notebooks --out notebooks`, or run it as plain Python
# (`python tutorials/00_data_and_sampling.py`): the figures then go to
# `tutorial-output/` (or `$REFSYNTH_TUTORIAL_OUT`).

# %%
import matplotlib.pyplot as plt
import numpy as np
from _course import save
from scipy import ndimage

from refsynth.acquisition import distance_driven, stripes, unknown_fraction, x_stripes_for_fraction
from refsynth.evaluation import linear_fill, mar, nearest_fill
from refsynth.scenes import motorcycle, synthetic_room

# %% [markdown]
# ## 1. A scene: an intensity image and its range, on one grid
#
# Everything in refsynth starts from a *registered* pair: an intensity image
# and a range image of the same scene, pixel for pixel (tutorial 3 shows how
# the robot gets there). `synthetic_room` ray-casts an indoor scene — walls,
# floor, boxes, a room divider — and shades it, so its range is exact, in
# metres. A `Scene` holds `intensity` (grey here, in [0, 1]), `range` (NaN
# where there is no ground truth), `units` and `name`.

# %%
room = synthetic_room((128, 128), seed=0)
print(f"{room.name}: intensity {room.intensity.shape}, range {room.range.shape} in "
      f"{room.units}, {np.nanmin(room.range):.2f}–{np.nanmax(room.range):.2f} m, "
      f"ground truth on {100 * room.has_truth.mean():.0f} % of the pixels")

fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
axes[0].imshow(room.intensity, cmap="gray", vmin=0, vmax=1)
axes[0].set_title("intensity")
shown = axes[1].imshow(room.range, cmap="viridis")
axes[1].set_title("range (m)")
fig.colorbar(shown, ax=axes[1], fraction=0.046)
for ax in axes:
    ax.set_axis_off()
save(fig, "00_room.png")

# %% [markdown]
# Look for the three kinds of edge the paper cares about: a depth edge that
# shows in the intensity (a box against the wall), an intensity edge that is
# *not* a depth edge (the painting, the floor tiles), and a depth edge that
# barely shows at all (the divider has the wall's colour).
#
# ## 2. A real scene: the Middlebury Motorcycle
#
# The paper's Table 4 uses Middlebury stereo pairs. Their "range" is
# *disparity* in pixels — large is near — and real ground truth has holes
# (NaN here). The paper works at 450 × 375; this course mostly uses 128 × 128
# (squeezed horizontally), which runs in about a second per fill.

# %%
bike = motorcycle(128)
print(f"{bike.name}: intensity {bike.intensity.shape}, {bike.units} "
      f"{np.nanmin(bike.range):.2f}–{np.nanmax(bike.range):.2f}, "
      f"ground truth on {100 * bike.has_truth.mean():.1f} % of the pixels")

fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
axes[0].imshow(bike.intensity)
axes[0].set_title("intensity (colour)")
shown = axes[1].imshow(bike.range, cmap="viridis")
axes[1].set_title("disparity (px); NaN = white")
fig.colorbar(shown, ax=axes[1], fraction=0.046)
for ax in axes:
    ax.set_axis_off()
save(fig, "00_motorcycle.png")

# %% [markdown]
# ## 3. Partial range: the paper's samplings
#
# A *sampling* is a boolean mask, `True` where the range is measured. The
# partial range is the dense one with `NaN` elsewhere:
# `partial = np.where(known, range, np.nan)`.
#
# * **Grid stripes** (Table 1): known lines `rw` pixels wide every
#   `rw + xw` pixels, along both axes, so the unknown part is a grid of
#   `xw × xw` holes: `stripes(shape, rw, xw, axes="xy")`.
# * **Vertical stripes** (Table 4): whole columns, as a laser that sweeps
#   vertical slices gives: `x_stripes_for_fraction(shape, 0.78)` picks the
#   gap for a requested unknown fraction.
# * **Distance-driven** (§3.1.1, Fig. 2): the robot scans vertical slices
#   more densely where the scene is far ("the farther we are from an object,
#   the smaller it looks"): `distance_driven(coarse_range, 0.4)` from a coarse
#   first pass.
#
# The tables quote the "% of area with missing range". The paper's Table 1
# gives 39, 39, 61 and 76.5 %; ours come out a little different because the
# fraction depends on where the pattern starts (its *phase*), which the paper
# does not give:

# %%
layouts = [(24, 80), (10, 20), (5, 25), (3, 28)]
for rw, xw in layouts:
    fractions = [unknown_fraction(stripes(room.shape, rw, xw, axes="xy", phase=p))
                 for p in range(rw + xw)]
    print(f"grid {rw}/{xw}: {100 * fractions[0]:.1f} % unknown at phase 0, "
          f"{100 * min(fractions):.1f}–{100 * max(fractions):.1f} % over all phases")

samplings = {
    "grid 24/80": stripes(room.shape, 24, 80, axes="xy"),
    "grid 10/20": stripes(room.shape, 10, 20, axes="xy"),
    "grid 5/25": stripes(room.shape, 5, 25, axes="xy"),
    "grid 3/28": stripes(room.shape, 3, 28, axes="xy"),
    "x-stripes 60 %": x_stripes_for_fraction(room.shape, 0.60),
    "distance-driven, 40 % known": distance_driven(room.range, 0.4),
}
fig, axes = plt.subplots(1, len(samplings), figsize=(14, 2.8))
for ax, (name, known) in zip(axes, samplings.items()):
    ax.imshow(np.where(known, room.range, np.nan), cmap="viridis")
    ax.set_title(f"{name}\n{100 * unknown_fraction(known):.1f} % unknown", fontsize=9)
    ax.set_axis_off()
save(fig, "00_samplings.png")

# %% [markdown]
# The distance-driven mask (last panel) puts its slices closer together on
# the far back wall and further apart on the near boxes and side walls.
#
# ## 4. Eq. 13: the mean absolute residual (MAR)
#
# $$\mathrm{MAR} = \frac{\sum_{i,j} |R_1(i,j) - R_2(i,j)|}
#   {\text{number of unknown range pixels}}$$
#
# `R_1` is the synthesized range, `R_2` the ground truth. The sum runs over
# the pixels that were **unknown** — the measured ones are copied unchanged,
# and counting them would only dilute the error — and, on real data, that
# **have ground truth**. It is one line of numpy; refsynth's
# `refsynth.evaluation.mar` is the same, with checks on its inputs.

# %%
known = samplings["grid 5/25"]
partial = np.where(known, room.range, np.nan)
nearest = nearest_fill(room.intensity, partial)
scored = ~known & np.isfinite(room.range)
by_hand = np.abs(nearest - room.range)[scored].mean()
print(f"Eq. 13 by hand {by_hand:.6f} m, "
      f"refsynth.evaluation.mar {mar(nearest, room.range, known):.6f} m")
print(f"a perfect fill scores {mar(room.range, room.range, known):.1f}")

# %% [markdown]
# ## 5. The bar to clear: the nearest-neighbour fill
#
# The simplest fill copies each unknown pixel's range from the nearest
# measured pixel. It never blurs across a depth edge, and indoor range is
# mostly piecewise flat, so it is hard to beat on MAR. `linear_fill`
# (Delaunay interpolation) is the other cheap baseline. Here both are scored
# on each sampling of the room, beside the mean distance from an unknown
# pixel to its nearest measured pixel:

# %%
rows = []
for name, known in samplings.items():
    partial = np.where(known, room.range, np.nan)
    distance = ndimage.distance_transform_edt(~known)[~known].mean()
    nn = mar(nearest_fill(room.intensity, partial), room.range, known)
    lin = mar(linear_fill(room.intensity, partial), room.range, known)
    rows.append((name, unknown_fraction(known), distance, nn, lin))
    print(f"{name:>28}: {100 * unknown_fraction(known):5.1f} % unknown, mean distance "
          f"{distance:5.2f} px, nearest MAR {nn:.3f} m, linear MAR {lin:.3f} m")

by_distance = [name for name, *_ in sorted(rows, key=lambda row: row[2])]
by_nearest = [name for name, *_ in sorted(rows, key=lambda row: row[3])]
print(f"ranked by mean distance and by nearest's MAR: "
      f"{'the same order' if by_distance == by_nearest else 'different orders'}")
grid_24, grid_10 = rows[0], rows[1]
print(f"at {100 * grid_24[1]:.1f} % unknown both: grid 24/80 {grid_24[3]:.3f} m against "
      f"grid 10/20 {grid_10[3]:.3f} m, {grid_24[3] / grid_10[3]:.1f} times the error")

# %% [markdown]
# Read the table for two lessons that the rest of the course leans on.
#
# * **The layout matters as much as the fraction.** Grids 24/80 and 10/20
#   leave the same share unknown, but the 80-pixel holes put an unknown pixel
#   several times further from any measurement than the 20-pixel ones, and
#   the error is several times larger (the printed ratio); the paper's
#   Table 1 shows the same effect for NP (36.36 against 5.76 cm). Ranked by
#   the mean distance to the nearest measurement, the samplings come out in
#   the same order as ranked by the nearest fill's error (the line above
#   says whether that holds).
# * **Vertical stripes and the distance-driven columns are easy** for simple
#   fills: narrow gaps (the mean distance is a pixel or two), with
#   measurements on both sides of each gap in every row, so even the linear
#   fill does very well on the room, whose walls are planes. The grids, with
#   wide square holes, are where a method that *reads the intensity* can
#   show what it is worth — which is why tutorial 1 uses grid 5/25.
#
# Keep these numbers in mind: in tutorial 1, NP has to beat the nearest fill
# on the same case.
#
# ## Exercises
#
# Solutions: `tutorials/solutions/00_data_and_sampling.py` (the test suite
# runs it).
#
# 1. **Eq. 13 over the wrong pixels.** Score the nearest fill of grid 5/25
#    over *all* pixels with ground truth instead of the unknown ones. Show
#    that the result is exactly MAR times the unknown fraction, and say why a
#    paper must state which pixels it averages over.
# 2. **Layout against fraction.** Make three grid samplings that leave about
#    the same fraction unknown (say 64–66 %) with holes of different widths
#    (5/25, 8/40 and 12/60 do). Does the nearest fill's MAR follow the
#    fraction or the hole size?
# 3. **Fig. 2 on a real scene.** On the Motorcycle, take the distance-driven
#    columns for 40 % known (use `1 / disparity` as the coarse range: larger
#    is farther), and as many evenly spaced columns. Which gives the nearest
#    fill the lower MAR, and why? (Never count pixels without ground truth as
#    known: `known & bike.has_truth`.)
