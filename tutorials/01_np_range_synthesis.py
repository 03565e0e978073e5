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
# # Tutorial 1 — range synthesis by non-parametric sampling (NP)
#
# Torres-Méndez & Dudek (IJCV 2008), §3.2.1, §3.2.2 (Eqs. 2–5) and §3.2.4
# (Eqs. 10–12).
#
# **Before this tutorial**: tutorial 0 — a scene, a sampling, the partial
# range, MAR (Eq. 13) and the nearest-neighbour fill.
#
# **After it** you can compute Eq. 2 between two partial neighbourhoods and
# say what each of its terms does; describe how NP picks the range it copies
# (Eqs. 3–5); compute the three terms of the fill order (Eqs. 10–12) on the
# fill front and read the order they give; run NP and its ablations, and say
# where NP beats the nearest fill and where it does not, and why.
#
# A robot measured the range of only part of a scene but has an intensity
# image of all of it. NP fills the missing range one pixel at a time: it
# compares the pixel's neighbourhood (intensity, plus whatever range is already
# there) with nearby neighbourhoods that do have range (**Eq. 2**), keeps the
# best few (**Eqs. 3–5**) and copies the centre range of one of them. The order
# in which pixels are filled matters as much as the matching (**Eqs. 10–12**).
#
# Open this file as a notebook (Jupyter with jupytext, JupyterLab, VS Code),
# build it with `python -m refsynth notebooks --out notebooks --only 01`, or
# run it as plain Python (`python tutorials/01_np_range_synthesis.py`; figures
# in `tutorial-output/`).

# %%
import matplotlib.pyplot as plt
import numpy as np
from _course import save
from scipy import ndimage

import refsynth
from refsynth.acquisition import stripes, unknown_fraction
from refsynth.evaluation import linear_fill, mar, nearest_fill
from refsynth.plotting import result_figure
from refsynth.scenes import motorcycle, synthetic_room
from refsynth.synthesis import (
    canny,
    confidence_term,
    data_term,
    edge_count,
    fill_front,
    gaussian_window,
    neighbourhood_distance,
    priority,
    to_grey,
)

# %% [markdown]
# ## 1. The Gaussian window and Eq. 2
#
# $$\|N_a - N_b\| = \sum_v G(\sigma, v - v_0)\,
#   \big[(I^a_v - I^b_v)^2 + \lambda (R^a_v - R^b_v)^2\big]$$
#
# `G` weighs the window's centre most (σ = n / 6.4, as in Efros & Leung).
# Each term counts only where *both* neighbourhoods have data: the range term
# is skipped where either has no range — always at the centre of the
# neighbourhood being filled, since that is what we are looking for.
# Intensity and range are both normalised to [0, 1] before they are compared,
# and the two terms weigh the same (λ = 1, refsynth's default). On a colour
# image the intensity term is the *sum* of the squared differences over the
# three channels, as Eq. 2 writes it (`channels="sum"`, the default;
# `channels="mean"` averages them), so colour weighs up to three times as
# much against range as a grey level would. The paper leaves the
# normalisation and λ open; the documentation's *Departures* page gives
# refsynth's choices and why. This
# cell calls Eq. 2 as written (`missing_range="ignore"`, the default of
# `neighbourhood_distance`); `synthesize` also charges a candidate for range
# it lacks where the target has some (`missing_range="mean"`, a departure).

# %%
G = gaussian_window(5)
print(f"G (5x5), centre weight {G[2, 2]:.3f}, corner weight {G[0, 0]:.4f}")

rng = np.random.default_rng(0)
intensity_a = rng.random((5, 5))
range_a = np.where(rng.random((5, 5)) < 0.5, rng.random((5, 5)), np.nan)
range_a[2, 2] = np.nan  # the centre: unknown
intensity_b = intensity_a + 0.05
range_b = rng.random((5, 5))

d_same = neighbourhood_distance(intensity_a, range_a, intensity_a, range_a)
d_ab = neighbourhood_distance(intensity_a, range_a, intensity_b, range_b)
d_ba = neighbourhood_distance(intensity_b, range_b, intensity_a, range_a)
d_intensity_only = neighbourhood_distance(
    intensity_a, range_a, intensity_b, range_b, range_weight=0.0
)
print(f"Eq. 2: identical {d_same:.4f}, a-b {d_ab:.4f}, b-a {d_ba:.4f} (symmetric)")
print(f"       intensity term alone {d_intensity_only:.4f} (= 0.05² = 0.0025: the shift)")

# %% [markdown]
# The intensity term alone is exactly the squared shift, 0.05², because the
# weights of `G` sum to 1. The range term is the rest of `a-b`: the two
# neighbourhoods' ranges are unrelated random numbers, and even at λ = 1
# that disagreement dominates (it is the other 0.09 of `a-b`, some 36 times
# the intensity term). These patches have one channel, so the channel sum
# does not enter here.
#
# ## 2. The case: a real image, the paper's grid
#
# We use the Middlebury Motorcycle at 128 × 128 (the image of the paper's
# Table 4, at a size that runs in about a second per fill) with the grid
# sampling of Tables 1 and 3: known stripes 5 pixels wide, 25-pixel holes
# between them. Pixels without ground truth are never known (nothing to
# give) and never scored. Why this case: it is the paper's setting on real
# data, and with refsynth's defaults the paper's two main claims about NP
# show on it beyond NP's seed-to-seed spread — NP beats the simple fills,
# and the edge term helps (section 4 says why; the test suite checks both
# statements). On the synthetic rooms too the edge term helps beyond the
# spread (exercise 1).

# %%
scene = motorcycle(128)
known = stripes(scene.shape, 5, 25, axes="xy") & scene.has_truth
partial = np.where(known, scene.range, np.nan)
edges = canny(to_grey(scene.intensity), sigma=0.8)
print(f"scene {scene.name}: {scene.units} {np.nanmin(scene.range):.2f}–"
      f"{np.nanmax(scene.range):.2f}, {100 * unknown_fraction(known):.1f} % unknown, "
      f"{int(edges.sum())} edge pixels")

fig, axes = plt.subplots(1, 3, figsize=(10, 3.4))
axes[0].imshow(scene.intensity)
axes[0].set_title("intensity")
axes[1].imshow(edges, cmap="gray")
axes[1].set_title("Canny edges, σ = 0.8")
axes[2].imshow(partial, cmap="viridis")
axes[2].set_title("partial disparity (NaN = white)")
for ax in axes:
    ax.set_axis_off()
save(fig, "01_scene.png")

# %% [markdown]
# (`synthesize` finds its own edges the same way, after bringing the
# intensity to its span and rounding it; `result.edges` holds the map it
# used.)
#
# ## 3. The fill front and the priority terms (Eqs. 10–12)
#
# The front δΩ is the set of unknown pixels that touch known ones. Each front
# pixel gets $P = C \cdot D + 1/(1 + E)$:
#
# * **C** (Eq. 11) — the share of its window that is known (weighted by the
#   confidence of what is known);
# * **D** (Eq. 12) — $1 - |\nabla I^\perp \cdot n|/\alpha$: low where the
#   *range* isophote flows into the hole along the front normal, i.e. near a
#   depth discontinuity that the known range already shows;
# * **E** — the number of intensity-edge pixels in the window. Edge pixels
#   themselves go last.

# %%
low, span = np.nanmin(partial), np.nanmax(partial) - np.nanmin(partial)
range_norm = np.where(known, (partial - low) / span, 0.0)
confidence = known.astype(float)
front = fill_front(known)
C = confidence_term(confidence, 5)
D = data_term(range_norm, known, 5)
E = edge_count(edges, 5)
P = priority(confidence, range_norm, known, edges, 5)
print(f"front pixels: {int(front.sum())}")
print(f"on the front: C in [{C[front].min():.2f}, {C[front].max():.2f}], "
      f"D in [{D[front].min():.2f}, {D[front].max():.2f}] (above 0.95 on "
      f"{100 * np.mean(D[front] > 0.95):.0f} % of it), E in [{E[front].min():.0f}, "
      f"{E[front].max():.0f}], P in [{np.nanmin(P):.2f}, {np.nanmax(P):.2f}]")

fig, axes = plt.subplots(1, 4, figsize=(13, 3.4))
for ax, (name, term) in zip(axes, [("C (Eq. 11)", C), ("D (Eq. 12)", D), ("E", E),
                                  ("P (Eq. 10)", P)]):
    shown = np.where(front, term, np.nan)
    im = ax.imshow(shown, cmap="plasma")
    ax.set_title(f"{name} on the front")
    ax.set_axis_off()
    fig.colorbar(im, ax=ax, fraction=0.046)
save(fig, "01_priority_terms.png")

# %% [markdown]
# C is highest at the corners of each hole, where two known stripes meet,
# and low beside the patches without ground truth (they count as unknown).
# D is close to 1 on most of the front (the printed share): the known range
# changes little along a stripe except where the stripe crosses a depth
# edge, and only there does D defer a pixel. E is what makes the order read
# the image: the bike is a clutter of intensity edges, so its outline waits
# while the smoother floor and wall are filled first (section 4 prints the
# mean fill time near edges and elsewhere).
#
# ## 4. NP synthesis, against the nearest and linear fills
#
# `refsynth.synthesize` runs the whole loop: pick the top-priority front pixel,
# gather candidates within `r = 10` whose centre has range (Eq. 3), score them
# with Eq. 2, keep those within `(1 + ε)` of the best (Eq. 5, ε = 0.1) and copy
# the centre range of one of them, drawn with the seeded generator. The result
# carries the fill order and the confidence each pixel received.
#
# Every run in this tutorial reads NP's fill itself, with
# `readings={"median": 0}`. By default refsynth then gives each synthesized
# pixel the median of its 3 × 3 window, a step after the fill that tutorial 2's
# last section takes up.

# %%
FILL = {"median": 0}  # NP's fill as filled, without the median after it
result = refsynth.synthesize(scene.intensity, partial, seed=0, readings=FILL)
units = scene.units
mar_np = mar(result.range, scene.range, known)
mar_nn = mar(nearest_fill(scene.intensity, partial), scene.range, known)
mar_linear = mar(linear_fill(scene.intensity, partial), scene.range, known)
print(f"NP: MAR {mar_np:.3f} over {len(result.order)} synthesized pixels; "
      f"nearest-neighbour fill: MAR {mar_nn:.3f}; linear fill: MAR {mar_linear:.3f} ({units})")
print(f"first pixels filled (row, col): {result.order[:3].tolist()}")

save(result_figure(scene.intensity, result.edges, partial, result.range, scene.range,
                   units=units, title="NP on the Motorcycle, grid 5/25"), "01_np_result.png")

scored = ~known & scene.has_truth
distance = ndimage.distance_transform_edt(~known)  # to the nearest measured pixel
nearest = nearest_fill(scene.intensity, partial)
for low_px, high_px in [(0, 3), (3, 6), (6, np.inf)]:
    band = scored & (distance > low_px) & (distance <= high_px)
    np_band = np.abs(result.range - scene.range)[band].mean()
    nn_band = np.abs(nearest - scene.range)[band].mean()
    print(f"{low_px}-{high_px} px from the known range: NP {np_band:.3f}, "
          f"nearest {nn_band:.3f}, ratio {np_band / nn_band:.2f}")
near_edge = ndimage.binary_dilation(result.edges, iterations=2)
error = np.abs(result.range - scene.range)
print(f"NP's error within 2 px of an intensity edge {error[scored & near_edge].mean():.3f}, "
      f"elsewhere {error[scored & ~near_edge].mean():.3f}")

# %% [markdown]
# NP is ahead of the nearest fill at every distance from the stripes (every
# ratio is below 1): where the nearest fill switches surfaces halfway across
# a hole, NP continues each surface until the intensity says it ends. Its
# error is concentrated at the intensity edges (the last line): the bike's
# outline, its spokes and cables, a few pixels wide, where a wrong copy
# puts the floor's disparity on the bike or the other way round. Look at the
# residual panel.
#
# ### The fill order, and what the ablations change
#
# Colour each pixel by *when* it was filled. The paper's Fig. 7 compares this
# information-driven order with onion peeling (boundary inwards). Turning off
# the edges (Table 3's "no-edge" column) or the isophotes (Fig. 16) changes
# the order, and with it the result. NP draws at random (Eq. 5), so each
# variant runs with three seeds: a difference smaller than the two spreads
# together is a tie.

# %%
when = np.full(scene.shape, np.nan)
when[result.order[:, 0], result.order[:, 1]] = np.arange(len(result.order))
onion = refsynth.synthesize(scene.intensity, partial, seed=0, ordering="onion", readings=FILL)
when_onion = np.full(scene.shape, np.nan)
when_onion[onion.order[:, 0], onion.order[:, 1]] = np.arange(len(onion.order))

fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
axes[0].imshow(when, cmap="turbo")
axes[0].set_title("priority order (Eqs. 10–12)")
axes[1].imshow(when_onion, cmap="turbo")
axes[1].set_title("onion-peel order")
for ax in axes:
    ax.set_axis_off()
save(fig, "01_fill_order.png")
rank = when / np.nanmax(when)  # 0: filled first, 1: filled last
print(f"mean fill time (0 = first, 1 = last): within 2 px of an edge "
      f"{np.nanmean(rank[near_edge]):.2f}, elsewhere {np.nanmean(rank[~near_edge]):.2f}")

variants = {"priority order": {}, "onion order": {"ordering": "onion"},
            "no edges": {"use_edges": False}, "no isophotes": {"use_isophotes": False}}
first = {"priority order": result, "onion order": onion}  # seed 0 of these ran above
scores = {}
for label, kwargs in variants.items():
    runs = [mar((first[label] if s == 0 and label in first else
                 refsynth.synthesize(scene.intensity, partial, seed=s, **kwargs,
                                     readings=FILL)).range,
                scene.range, known) for s in range(3)]
    scores[label] = (np.mean(runs), np.std(runs, ddof=1))
    print(f"{label:>15}: MAR {scores[label][0]:.3f} ± {scores[label][1]:.3f} (3 seeds)")


def verdict(ours, theirs):
    """'better', 'worse' or 'a tie' for the first (mean, sd) against the second."""
    if abs(ours[0] - theirs[0]) <= ours[1] + theirs[1]:
        return "a tie"
    return "better" if ours[0] < theirs[0] else "worse"


for other, claim in [("onion order", "Fig. 7"), ("no edges", "Table 3, Fig. 13"),
                     ("no isophotes", "Fig. 16")]:
    print(f"priority order with everything on, against {other} ({claim}): "
          f"{verdict(scores['priority order'], scores[other])}")

# %% [markdown]
# The last three lines check the paper's three claims about the order on this
# case. Under refsynth's readings of the fill the edge term wins beyond the
# spread and the onion order and the isophotes tie. Two readings shape that.
# Eq. 2 sums the colour channels (chosen on the full-size Motorcycle), which
# weighs the colour about three times as much against the range already filled;
# with Eq. 5's value copy (`range_copy="value"`) that leaves all three claims ties
# on this small grid case (the priority order scores 0.510 ± 0.032), and
# with the value copy and the channel mean (`channels="mean"`) it scores
# 0.463 ± 0.015 and beats both the onion order (0.524 ± 0.007) and the order
# without edges (0.529 ± 0.028) beyond the spread. The default copy shifts
# the copied value by the range difference between the two windows
# (`range_copy="offset"`, chosen on the full-size Motorcycle: the
# documentation's *Departures* page): a slanted surface then fills as a
# surface, every order gains, and the order that keeps each surface to its
# own side of an edge gains most. What each term does, and so what to look
# for:
#
# * **Edges** (the claim this case was chosen for; a win beyond the spread,
#   see above). Without `E`, nothing stops the fill from
#   running across a depth edge: a pixel just past the bike's outline is
#   filled from whichever side is more confident, so the floor's disparity
#   leaks onto the bike or the other way round. With `E`, pixels near edges
#   wait, and edge pixels go last, so each surface is filled from its own
#   side up to the edge.
# * **Onion order.** Peeling layer by layer fills every hole from all four
#   sides at once, edges or not, so the surfaces meet wherever the layers
#   meet; the priority order follows the intensity instead. Which wins
#   depends on the case (here it is a tie): the documentation's *Results*
#   find the priority order ahead on the room's grids (or tied), and onion
#   peeling ahead on its vertical stripes only at the widest gaps (85 %) and
#   on the distance-driven columns — with Eq. 5's value copy it was ahead at
#   every x-stripe fraction (exercise 3 shows why, and why the shifted copy
#   closes the gap).
# * **Isophotes.** `D` is close to 1 on most of the front (section 3), so it
#   can only reorder the few pixels where a stripe crosses a depth edge; a
#   tie here is no surprise. The paper reports a clear gain on real images
#   (Fig. 16); the documentation's *Results* say how far refsynth reproduces it.
#
# ### A case where NP loses to the nearest fill
#
# Take a synthetic room (seed 3) at 64 × 64 with the same 5/25 grid, and NP
# loses to the nearest fill. The
# grid is in pixels: at 64 × 64 a 25-pixel hole spans four times as much of
# the room (twice as wide, twice as high), whole boxes fit inside one hole,
# and nothing measured tells NP what is there. Scale the grid with the image
# (3/13) and the comparison turns round:

# %%
small = synthetic_room((64, 64), seed=3)
for rw, xw in [(5, 25), (3, 13)]:
    small_known = stripes(small.shape, rw, xw, axes="xy")
    small_partial = np.where(small_known, small.range, np.nan)
    small_np = np.mean([mar(refsynth.synthesize(small.intensity, small_partial, seed=s,
                                                readings=FILL).range,
                            small.range, small_known) for s in range(3)])
    small_nn = mar(nearest_fill(small.intensity, small_partial), small.range, small_known)
    print(f"64x64, grid {rw}/{xw} ({100 * unknown_fraction(small_known):.0f} % unknown): "
          f"NP MAR {small_np:.3f} m (3 seeds), nearest {small_nn:.3f} m")

# %% [markdown]
# ## 5. Confidence
#
# A measured pixel has confidence 1. A synthesized pixel gets its
# confidence when it is filled, from its Eq. 11 term at that moment and the
# confidence of the neighbourhood it matched best; how exactly the two
# combine is a reading of the paper's sentence (the documentation's
# *Departures* page gives refsynth's). What matters for the fill order is how fast the
# confidence decays into the holes, which the next cell measures ring by
# ring (ring 1 touches the measured stripes).

# %%
fig, ax = plt.subplots(figsize=(4, 3.6))
im = ax.imshow(result.confidence, cmap="viridis", vmin=0, vmax=1)
ax.set_title("NP confidence")
ax.set_axis_off()
fig.colorbar(im, ax=ax, fraction=0.046)
save(fig, "01_confidence.png")
median = np.median(result.confidence[~known])
print(f"confidence of synthesized pixels: median {median:.3f}")
rings = ndimage.distance_transform_cdt(~known, metric="chessboard")
print("median confidence by ring into the holes: " + ", ".join(
    f"{ring}: {np.median(result.confidence[rings == ring]):.3f}" for ring in range(1, 6)))
if median < 0.05:
    print("the confidence has all but vanished a few rings into each hole: there, Eq. 10's "
          "first term C·D is ~0 and the order follows the edge term 1/(1 + E) alone")
else:
    print("the confidence stays well above 0 inside the holes: Eq. 10's first term C·D "
          "still orders the fill there, beside the edge term")

# %% [markdown]
# The printed lines say which regime this version of refsynth is in. Under
# a product reading (the Eq. 11 term times the best match's confidence),
# each ring multiplies the confidence by factors below one, so it falls ring
# by ring; a reading that gives a pixel the best match's confidence alone
# decays more slowly. Either way the confidence map is a "how far from a
# measurement" map, not an error estimate: compare it with the residual
# panel above.
#
# ## Exercises
#
# Solutions: `tutorials/solutions/01_np_range_synthesis.py` (the test suite
# runs it).
#
# 1. **Turn off the edge term and explain the MAR change**, on this case and
#    on the synthetic room of seed 3 (same grid), three seeds each. Where in
#    the image does the error grow? Measured against NP's spread between
#    seeds, where is the effect clearer, and why?
# 2. **Implement Eq. 12 yourself** — the mean range gradient over the
#    window's adjacent pairs that both have range, turned by 90°, against the
#    normalised Sobel gradient of the filled mask — and compare it with
#    `refsynth.synthesis.data_term` on this case's front.
# 3. **Make the fill run in onion order and look at the streaks**: on
#    vertical stripes (`x_stripes_for_fraction(shape, 0.78)`) on room 0,
#    compare the residuals of the priority and the onion order. Which leaves
#    long vertical streaks of error, and why?
