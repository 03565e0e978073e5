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
# # Tutorial 6 — check your own port against the oracle
#
# Torres-Méndez & Dudek (IJCV 2008), §3.2.2 (Eqs. 2–5) and §3.2.4
# (Eqs. 10–12); refsynth's numeric contract and its oracle.
#
# **Before this tutorial**: tutorial 1 — Eq. 2, NP's candidate set and draw
# (Eqs. 3–5), the fill order (Eqs. 10–12).
#
# **After it** you can export refsynth's golden cases, write a port (here in
# Python, in C++ or CUDA tomorrow) that takes the contract's prepared inputs
# and replays refsynth's random numbers, check it with `oracle check`, read the
# first-mismatch report (case, step, pixel, expected, got), find the bug it
# points at, and fix it.
#
# refsynth is also an *oracle*: a faster implementation of NP or BP must give
# the same numbers. That is possible only because every quantity that feeds a
# decision is exact (the **numeric contract**: intensity and range quantised to
# 2⁻¹⁶ of their spans, Eq. 2's Gaussian window an integer table, confidences on
# a 2⁻⁴⁰ grid), so a port can compute Eq. 2 in any order — BLAS, GPU
# reductions, int64 — and still take the same argmin. The golden cases carry,
# besides inputs and outputs, every step of the literal reference's run: the
# pixel chosen and its priority terms, the candidate list with its Eq. 2
# distances, the Eq. 5 set, the random number consumed and the value drawn.
#
# Open this file as a notebook, build it with
# `python -m refsynth notebooks --out notebooks --only 06`, or run it as plain
# Python (`python tutorials/06_check_your_port.py`; figures in
# `tutorial-output/`).

# %%
import subprocess
import sys
import time

import matplotlib.pyplot as plt
import numpy as np
from _course import OUT, save

from refsynth.numeric import NO_RANGE, on_confidence_grid
from refsynth.oracle import build_cases, check_function, export_cases, load_case
from refsynth.oracle.cases import select_cases
from refsynth.synthesis.reference import (
    confidence_term,
    disc_offsets,
    eq2_distance,
    priority_terms,
)

START = time.perf_counter()

# %% [markdown]
# ## 1. Export the golden cases
#
# From a shell: `python -m refsynth oracle export oracle-cases` writes all of
# them (whole NP and BP runs from 8×8 to 64×64, and per-equation batches), as
# `manifest.json`, `schema.json` and one `cases/<name>.json` + `.npz` per case.
# Here we export the small NP runs only (`--cases 'np-8x8-*' 'np-12x10-*'`),
# with the same function the command calls.

# %%
CASES = OUT / "oracle-cases"
names = export_cases(CASES, select_cases(build_cases(), ["np-8x8-*", "np-12x10-*"]))
print("exported:", ", ".join(names))
meta, arrays = load_case(CASES, "np-8x8-noise")
print("options of np-8x8-noise:", meta["options"], "seed", meta["seed"])
for role in ("input", "prepared", "output", "trace"):
    keys = [k for k, spec in meta["arrays"].items() if spec["role"] == role]
    print(f"  {role:8s}: {', '.join(keys)}")

# %% [markdown]
# The *prepared* arrays are what a port starts from: `q_intensity` and
# `q_range` (the quantised intensity and range, −1 where the range is
# unknown), `window` (Eq. 2's integer Gaussian), and refsynth's random numbers:
# `tie` (Eq. 10's tie-break key per pixel) and `draws` (one uniform number per
# step, for Eq. 5). A port with another random generator uses these instead of
# its own, so its fill can be compared step by step.
#
# ## 2. A naive port
#
# The port below fills the unknown range the way §3.2 describes it: take the
# front pixel of highest priority (Eq. 10; ties by the smallest `tie`), gather
# the filled pixels within `r` (Eq. 3), compare neighbourhoods with Eq. 2 and
# copy from the best match (Eq. 4) — the value as Eq. 5 prints it: these small
# cases ask for `range_copy="value"` and the product rule of Eq. 11, so that a
# first port can leave out refsynth's offset copy (the default;
# exercise 1). It returns its outputs and its step trace
# in the oracle's layout. It reuses refsynth's Eq. 2 and priority terms so that
# it stays short; a real port would have its own (and check them on the `eq2`
# and `eq10_12` cases). It has one deliberate flaw: it copies from the best
# match instead of drawing from Eq. 5's near-best set.


# %%
def np_port(inputs, options, draw=False):
    """NP on the contract's prepared arrays; ``draw=False`` copies from the best match."""
    if options["method"] != "np" or options.get("ordering", "priority") != "priority":
        return None   # this port does BP nothing, nor the onion order (exercise 1)
    qi, q = inputs["q_intensity"], inputs["q_range"].copy()
    window, tie, draws = inputs["window"], inputs["tie"], inputs["draws"]
    n, radius, eps = options["neighbourhood"], options["radius"], options.get("epsilon", 0.1)
    h, (H, W) = n // 2, q.shape
    edges = inputs["edges"] & options["use_edges"]
    qi_pad = np.pad(qi, ((h, h), (h, h), (0, 0)), mode="symmetric")   # mirrored intensity
    q_pad = np.pad(q, h, constant_values=NO_RANGE)                    # no range off the image
    filled, out = q != NO_RANGE, inputs["partial_range"].copy()
    conf = filled.astype(float)
    E = [[int(edges[max(r - h, 0):r + h + 1, max(c - h, 0):c + h + 1].sum()) for c in range(W)]
         for r in range(H)]

    def patch(r, c):
        return qi_pad[r:r + n, c:c + n], q_pad[r:r + n, c:c + n]

    trace = {k: [] for k in ("step_pixel", "cand_pixel", "cand_distance", "step_best",
                             "step_source", "step_confidence")}
    starts = [0]
    for step in range(int((~filled).sum())):
        key, p = None, None
        for r in range(H):
            for c in range(W):
                if filled[r, c] or not filled[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2].any():
                    continue
                C, D, Et = priority_terms(r, c, filled, q, conf,
                                          E[r][c] if options["use_edges"] else None, n,
                                          use_isophotes=options.get("use_isophotes", True))
                k = (int(edges[r, c]), -(C * max(D, 0.0) + Et), int(tie[r, c]))
                if key is None or k < key:
                    key, p = k, (r, c)
        r, c = p
        cands = [(r + a, c + b) for a, b in disc_offsets(radius)
                 if 0 <= r + a < H and 0 <= c + b < W and filled[r + a, c + b]]
        d = [eq2_distance(*patch(r, c), *patch(a, b), window, options.get("range_weight", 1.0),
                          options.get("missing_range", "mean")) for a, b in cands]
        best = d.index(min(d))                                          # Eq. 4
        if draw:                                                        # Eq. 5 and the draw
            members = [i for i, x in enumerate(d) if x <= (1.0 + eps) * d[best]]
            source = cands[members[int(draws[step] * len(members))]]
        else:
            source = cands[best]                                        # the naive choice
        new = confidence_term(conf, r, c, n) * confidence_term(conf, *cands[best], n)
        filled[r, c], q[r, c], out[r, c] = True, q[source], out[source]
        q_pad[r + h, c + h] = q[source]
        conf[r, c] = on_confidence_grid(new)
        for k, v in zip(trace, (p, cands, d, best, source, conf[r, c])):
            trace[k].extend(v) if k.startswith("cand_") else trace[k].append(v)
        starts.append(starts[-1] + len(cands))
    result = {k: np.array(v) for k, v in trace.items()}
    result.update(cand_start=np.array(starts), range=out, confidence=conf,
                  order=result["step_pixel"])
    return result


# %% [markdown]
# ## 3. Check it, and read the report
#
# `oracle check` calls the function on every case as `function(inputs,
# options)` and compares what it returns with the golden arrays: exactly, for
# integer and index arrays and (under the contract) for floats too. It compares
# the trace first, step by step, and names the **earliest** step at which any
# returned trace array differs: the first wrong decision, not its consequences
# (after one wrong copy, everything downstream differs too). From a shell the
# same check reads `python -m refsynth oracle check my_port:np_port --dir
# oracle-cases`, with the port saved as `my_port.py`.

# %%
report = check_function(np_port, CASES)
print(report)
mismatch = report.mismatch
golden = load_case(CASES, mismatch.case)[1]
s = mismatch.step
rows = slice(golden["cand_start"][s], golden["cand_start"][s + 1])
gamma = np.flatnonzero(golden["cand_in_gamma"][rows])
print(f"at step {s} refsynth's Eq. 5 set holds {gamma.size} candidates "
      f"{golden['cand_pixel'][rows][gamma].tolist()}; the best match is candidate "
      f"{golden['step_best'][s]}, the draw u = {golden['step_draw'][s]:.4f} picks member "
      f"floor(u · {gamma.size}) = {int(golden['step_draw'][s] * gamma.size)}")
earlier = [t for t in range(s) if golden["cand_in_gamma"][
    golden["cand_start"][t]:golden["cand_start"][t + 1]].sum() > 1]
print(f"earlier steps whose Eq. 5 set held more than one candidate: {len(earlier)}")

# %% [markdown]
# The report names the array (`step_source`: the pixel copied from), the step,
# the pixel being filled, and the two values. The golden trace explains it:
# at that step Eq. 5's set Γ′ holds several near-best matches, and refsynth's
# draw picks one that is not the best. (Had an earlier step held several
# members, its draw must have fallen on the best match.) The fix is Eq. 5 and the
# draw rule of the contract: the members are the candidates with
# `d ≤ (1 + ε) · d_best`, in candidate order, and the step's draw `u` picks
# member `floor(u · |Γ′|)`.

# %%
def fixed_port(inputs, options):
    return np_port(inputs, options, draw=True)


report = check_function(fixed_port, CASES)
print(report)
assert report.passed

# %% [markdown]
# The onion-order case was skipped (the port returned None for it): exercise 1.
# The figure shows the case the naive port failed: refsynth's fill order, and
# the pixels where the naive port's range ends up different — one wrong copy at
# the step the report named, and the errors it spread.

# %%
def case_call(name):
    """A case's ``(inputs, options)``, as ``oracle check`` passes them."""
    meta, arrays = load_case(CASES, name)
    inputs = {k: v for k, v in arrays.items()
              if meta["arrays"][k]["role"] in ("input", "prepared")}
    return inputs, dict(meta["options"], method=meta["kind"], seed=meta["seed"])


naive = np_port(*case_call(mismatch.case))
order_map = np.full(golden["range"].shape, np.nan)
order_map[tuple(golden["order"].T)] = np.arange(len(golden["order"]))
wrong = naive["range"] != golden["range"]
fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
im = axes[0].imshow(order_map, cmap="viridis")
axes[0].set_title(f"{mismatch.case}: refsynth's fill order")
fig.colorbar(im, ax=axes[0], fraction=0.046, label="step")
axes[1].imshow(wrong, cmap="Reds", vmin=0, vmax=1)
axes[1].plot(mismatch.pixel[1], mismatch.pixel[0], "o", mfc="none", mec="deepskyblue", mew=2.5,
             ms=16)
axes[1].set_title(f"naive port: {int(wrong.sum())} pixels differ\n(circle: step {s})")
for ax in axes:
    ax.set_xticks([]), ax.set_yticks([])
save(fig, "06_first_mismatch.png")
print(f"the naive port differs from refsynth on {int(wrong.sum())} of {len(golden['order'])} "
      "synthesized pixels")

# %% [markdown]
# ## 4. From the command line
#
# The same check runs from a shell on any importable `MODULE:FUNCTION`; here
# refsynth's own fast code, which must pass every case it handles. It exits
# with 0 on a pass, 1 on a mismatch (printing the one-line report), and 2 on a
# user error (a bad `MODULE:FUNCTION`, a missing folder).

# %%
command = [sys.executable, "-m", "refsynth", "oracle", "check", "refsynth.oracle:refsynth_fast",
           "--dir", str(CASES)]
done = subprocess.run(command, capture_output=True, text=True)
if done.returncode == 2 and "invalid choice: 'oracle'" in done.stderr:
    print("(this refsynth has no `oracle` command yet; the API call above is the same check)")
else:
    print(f"$ python -m refsynth oracle check refsynth.oracle:refsynth_fast --dir {CASES.name}")
    print(done.stdout.strip(), f"(exit {done.returncode})")
print(f"tutorial 6 ran in {time.perf_counter() - START:.0f} s")

# %% [markdown]
# Tolerances: integer, boolean and index arrays are always compared exactly.
# Floats are exact by default; `--tolerance float64` (rtol 10⁻⁹, atol 10⁻¹²)
# suits a port that computes the same decisions with other float operations,
# and `--tolerance float32` (rtol 10⁻⁴, atol 10⁻⁶) a float32 port. The
# registration cases (Eqs. 14–21) and Eq. 13 are not under the contract and
# are always compared at least at the float64 tolerance.
#
# ## Exercises
#
# Solutions: `tutorials/solutions/06_check_your_port.py` (the test suite
# runs it).
#
# 1. **Teach the port the onion order** (`ordering="onion"`, the case
#    `np-8x8-ramp`): the unknown pixels sorted by their chessboard distance to
#    the known range, ties by the prepared `onion_tie` (a permutation of the
#    unknown pixels in raster order). Check it until `np-8x8-ramp` passes.
#    Then teach it **the offset copy** (`range_copy="offset"`, NP's default,
#    the cases `np-14x18-planes` and `np-14x18-planes-value-copy`):
#    after the draw, shift the drawn value by the windows' consistent range
#    difference — the rule is in `refsynth.oracle.contract` (the
#    documentation's *Oracle* page) and in `refsynth.synthesis.range_copy`.
#    Which array does the oracle name on `np-14x18-planes` before you add it?
# 2. **Plant the dropped-factor bug**: give a synthesized pixel
#    the best match's confidence alone instead of `C(p) · C(best)`. Before you
#    run the check, predict from the golden trace (`step_C`) the first step the
#    oracle will report, and which array it names; then verify. Why can no
#    case hide this bug for even one step?
# 3. **A BP port with sum instead of max**: run refsynth's literal reference
#    BP (`refsynth.synthesis.reference.bp_reference`) with `product="sum"` on
#    the max-product case `bp-8x8-noise` (export it first) and return its
#    messages per sweep as `sweep_messages`. Which array and which sweep does
#    the oracle name, and why not `unary`?
