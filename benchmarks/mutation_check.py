"""Mutation check: do the tests catch wrong assembly of the equations? (issue #11)

Applies single-line mutations to the code that puts the paper's equations together — NP
(refsynth/synthesis/nonparametric/fill.py, its Eq. 2 table filltable.py), BP
(refsynth/synthesis/belief/: fill.py, its candidate search search.py, Eq. 6 in model.py, Eq. 9 in
messages.py), the fill order (priority.py,
its queue frontqueue.py, the onion order onion.py) and registration
(refsynth/registration/*.py): operators, indices, dropped terms, swapped arguments, among them
the seven of issue #11 — one at a time, in a *copy* of the project
(never the working tree), runs the relevant test files there with ``pytest -x -q``, and prints
killed / survived per mutation.

The literal references are mutated too: BP as printed (refsynth/synthesis/belief/reference.py,
``bpref-*``) and the oracle's reference (refsynth/synthesis/reference.py, ``oref-*``, NP's
and BP's steps). The oracle's expected values come from that reference, so a mutated
reference agrees with its own cases; its mutants are killed by the fast == reference
tests, the by-hand equations and the hashes of the cases the contract's rules name
(tests/test_oracle_contract.py).

A mutation is (file, an exact substring of one original line, its replacement). If the
original is not found (the code moved on), the mutation is skipped with a message. A
mutation known to be *equivalent* (it cannot change any result) says why; a survivor that is
not known to be equivalent is a gap in the tests.

Usage::

    python benchmarks/mutation_check.py                 # every mutation (15-30 min)
    python benchmarks/mutation_check.py --only np-eq5-draw bp-fixed-removed
    python benchmarks/mutation_check.py --list

Exit status: 0 if every non-equivalent mutation was killed, 1 otherwise.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

NP = "refsynth/synthesis/nonparametric/fill.py"
NP_REFERENCE = "refsynth/synthesis/nonparametric/reference.py"
RANGE_COPY = "refsynth/synthesis/range_copy.py"
BP = "refsynth/synthesis/belief/fill.py"
PRIORITY = "refsynth/synthesis/priority.py"
FILLTABLE = "refsynth/synthesis/filltable.py"
FRONTQUEUE = "refsynth/synthesis/frontqueue.py"
ONION = "refsynth/synthesis/onion.py"
BP_SEARCH = "refsynth/synthesis/belief/search.py"
BP_RANKING = "refsynth/synthesis/belief/ranking.py"
BP_MODEL = "refsynth/synthesis/belief/model.py"
MESSAGES = "refsynth/synthesis/belief/messages.py"
COMPLETION = "refsynth/synthesis/completion.py"
BELIEF_REF = "refsynth/synthesis/belief/reference.py"   # BP as printed (Fig. 6)
ORACLE_REFERENCE = "refsynth/synthesis/reference.py"   # the oracle's literal reference
REG = "refsynth/registration"

ORACLE_FAST = "tests/test_oracle.py::test_the_fast_code_passes_every_case_it_handles"
TESTS = {
    "np": ["tests/test_np_sampling.py", "tests/test_priority.py", "tests/test_synthesis.py",
           ORACLE_FAST, "tests/test_reference.py", "tests/test_assembly.py",
           "tests/test_np_speed_table.py", "tests/test_np_speed_front.py",
           "tests/test_mutation_gaps.py", "tests/test_range_copy.py",
           "tests/test_golden_hashes.py"],
    "bp": ["tests/test_bp.py", "tests/test_synthesis.py", ORACLE_FAST,
           "tests/test_reference.py", "tests/test_assembly.py", "tests/test_bp_speed_memory.py",
           "tests/test_bp_speed_sends.py", "tests/test_mutation_gaps.py",
           "tests/test_range_copy.py", "tests/test_bp_observation.py"],
    "priority": ["tests/test_priority.py", "tests/test_np_sampling.py", ORACLE_FAST,
                 "tests/test_reference.py", "tests/test_assembly.py",
                 "tests/test_np_speed_front.py", "tests/test_np_speed_steps.py",
                 "tests/test_mutation_gaps.py"],
    "completion": ["tests/test_completion.py", "tests/test_progress.py"],
    "np-reference": ["tests/test_np_reference.py"],
    "registration": ["tests/test_panorama.py", "tests/test_laser_camera.py",
                     "tests/test_registration_scenes.py"],
    # the literal references: fast == reference, the by-hand equations, and the oracle's
    # cases as the reference writes them (their hashes)
    "bp-reference": ["tests/test_bp_paper_reference.py", "tests/test_mutation_gaps.py"],
    "oracle-reference": ["tests/test_oracle_contract.py",
                         "tests/test_oracle.py::test_filling_the_defaults_kept_the_cases_"
                         "arrays_bit_for_bit", "tests/test_reference.py"],
}


@dataclass(frozen=True)
class Mutation:
    """One single-line change: where, what it replaces, which tests must catch it."""

    id: str
    area: str                 # a key of TESTS
    file: str
    original: str
    replacement: str
    what: str
    issue: bool = False       # one of the seven of issue #11
    equivalent: str = ""      # why it cannot change a result (expected to survive)


MUTATIONS = [
    # -- the seven of issue #11 ------------------------------------------------------
    Mutation("np-radius-ignored", "np", NP, "dr, dc = disc_offsets(radius)",
             "dr, dc = disc_offsets(10.0)", "Eq. 3's radius ignored in the gather", True),
    Mutation("np-eq5-draw", "np", NP,
             "j = int(members[int(draws[step] * members.size)])",
             "j = best", "the Eq. 5 draw replaced by the best match", True),
    Mutation("np-confidence-factor", "np", NP,
             "confidence = confidence_of(p) * confidence",
             "confidence = 1.0 * confidence",
             "a factor (C(p)) dropped from the confidence assigned", True),
    Mutation("bp-fixed-sides", "bp", BP,
             "ms = fixed_neighbour_terms(cp, fp, direction, side, quantised=True,",
             'ms = fixed_neighbour_terms(cp, fp, direction, "left" if side == "right" '
             'else "right", quantised=True,', "BP's fixed-neighbour sides swapped", True),
    Mutation("bp-eq6-order", "bp", BP_MODEL,
             "out[s] = psi(_overlap_sums(*pj, *pk, centres=pair), sigma_s)",
             "out[s] = psi(_overlap_sums(*pk, *pj, centres=pair), sigma_s)",
             "the Eq. 6 pair order swapped", True),
    Mutation("bp-fixed-removed", "bp", BP, "unary[node[s]] += psi(ms, sigma_s)",
             "unary[node[s]] += 0.0 * psi(ms, sigma_s)", "the fixed-neighbour terms removed",
             True),
    Mutation("bp-distance-alone", "bp", BP_SEARCH, "values = values + prior[mi]",
             "values = values", "candidates ranked by distance alone (no proximity prior)",
             True),
    # -- NP ----------------------------------------------------------------------------
    Mutation("np-eq4-argmax", "np", NP, "best = int(d.argmin())", "best = int(d.argmax())",
             "Eq. 4's argmin replaced by argmax (the best match's confidence)"),
    Mutation("np-eq5-strict", "np", NP,
             "members = np.less_equal(d, threshold).nonzero()[0]",
             "members = np.less(d, threshold).nonzero()[0]", "Eq. 5's ≤ replaced by <"),
    Mutation("np-eq5-minus", "np", NP, "scale = 1.0 + epsilon", "scale = 1.0 - epsilon",
             "Eq. 5's (1 + ε) replaced by (1 − ε)"),
    Mutation("np-eq5set-strict", "np", NP,
             "return np.flatnonzero(distances <= (1.0 + epsilon) * distances.min())",
             "return np.flatnonzero(distances < (1.0 + epsilon) * distances.min())",
             "Eq. 5's ≤ replaced by < in eq5_set (the oracle's per-equation batch)"),
    Mutation("np-eq5set-minus", "np", NP,
             "return np.flatnonzero(distances <= (1.0 + epsilon) * distances.min())",
             "return np.flatnonzero(distances <= (1.0 - epsilon) * distances.min())",
             "Eq. 5's (1 + ε) replaced by (1 − ε) in eq5_set (the oracle's batch)"),
    Mutation("np-draw-index", "np", NP,
             "j = int(members[int(draws[step] * members.size)])",
             "j = int(members[int(draws[step] * (members.size - 1))])",
             "the draw's index floor(u |Γ'|) off by one member"),
    Mutation("np-set-range-index", "np", NP, "set_range(p, value)",
             "set_range(q, value)", "the synthesized range written at the source"),
    Mutation("np-copy-value", "np", NP, "original_at[p] = original_at[q]",
             "original_at[p] = original_at[p]",
             "the source's range not copied to the output"),
    Mutation("np-offset-swapped", "np", FILLTABLE,
             "delta = np.subtract(self._rp, row[self.r0 : self.v0], self._delta)",
             "delta = np.subtract(row[self.r0 : self.v0], self._rp, self._delta)",
             "the offset copy's shift taken from q to p (its sign flipped)"),
    Mutation("np-offset-slack", "np", FILLTABLE,
             "slack = _SLACK * a",
             "slack = 2 * _SLACK * a",
             "NP's offset copy: the agreement test twice as loose"),
    Mutation("np-offset-one-side", "np", FILLTABLE,
             "if a * max(delta) - b > slack or b - a * min(delta) > slack:",
             "if a * max(delta) - b > slack:",
             "NP's offset copy: the agreement test on the largest δ only"),
    Mutation("np-offset-support", "np", FILLTABLE,
             "np.multiply(self._vp, row[self.v0 : -1], self._support)).tolist()",
             "np.multiply(self._vp, self._vp, self._support)).tolist()",
             "NP's offset copy: the agreement test over p's support, not the shared one"),
    Mutation("np-offset-draw", "np", NP, "shift = offset_shift(j)",
             "shift = offset_shift(best)",
             "NP's offset copy: the shift of the best match, not of the drawn member"),
    Mutation("np-offset-unit", "np", NP,
             "max((now - was) * span_unit + original_at[q], low)",
             "max((now - was) * span + original_at[q], low)",
             "the offset copy's shift not brought back to the caller's unit"),
    Mutation("bp-offset-psi", "bp", BP_MODEL,
             "lifted = values + (self.shifts[nodes] + SHIFT_LIFT)[:, :, None]",
             "lifted = values + SHIFT_LIFT",
             "BP's offset copy: Eq. 6 compares the labels' patches unmoved"),
    Mutation("bp-offset-fixed", "bp", BP,
             "cp = np.where(cp >= 0, cp + lift, -1.0)",
             "cp = np.where(cp >= 0, cp + SHIFT_LIFT, -1.0)",
             "BP's offset copy: a measured neighbour's term compares the label unmoved"),
    Mutation("bp-offset-target", "bp", BP,
             "target = observed if observed is not None else rq",
             "target = rq",
             "BP's offset copy: the shift read off the measured range, not the observations"),
    Mutation("rc-shifts-round", "bp", RANGE_COPY,
             "quotient = quotient + ((twice > safe) | ((twice == safe) & (quotient % 2 == 1)))",
             "quotient = quotient + (twice > safe)",
             "BP's shifts rounded half down, not half to even"),
    Mutation("rc-slack", "np", RANGE_COPY, "> _slack(tolerance) * a:",
             "> 2 * _slack(tolerance) * a:", "the offset copy's agreement test twice as loose"),
    Mutation("rc-shifts-slack", "bp", RANGE_COPY,
             "taken = (a > 0) & (spread <= _slack(tolerance) * a)",
             "taken = (a > 0) & (spread <= 2 * _slack(tolerance) * a)",
             "BP's shifts: the agreement test twice as loose"),
    Mutation("bp-tolerance-dropped", "bp", BP, "W, n,\n" + " " * 37 + "offset_tolerance)",
             "W, n,\n" + " " * 37 + "OFFSET_TOLERANCE)",
             "BP's labels shifted at NP's agreement whatever offset_tolerance says"),
    Mutation("api-tolerance-default", "bp", "refsynth/synthesis/api.py",
             'default_offset_tolerance(chosen["observation"])',
             'default_offset_tolerance("colorization")',
             "BP on NP's fill (the default preset's) keeps NP's agreement (2**-7)"),
    Mutation("rc-round", "np", RANGE_COPY,
             "if twice > denominator or (twice == denominator and quotient % 2):",
             "if twice > denominator:", "the shift rounded half down, not half to even"),
    Mutation("np-widened", "np", NP, "return flat[dist <= dist.min() + radius]",
             "return flat[dist <= dist.min()]", "the widened search loses its + r"),
    Mutation("np-onion-update", "np", NP,
             "fill(p, value, round(confidence * grid) * unit, update)",
             "fill(p, value, round(confidence * grid) * unit, True)",
             "priorities updated during the onion order",
             equivalent="the onion order never pops the priority queue (FrontQueue), so "
             "re-prioritising the front changes nothing the onion order reads"),
    Mutation("np-confidence-best", "np", NP,
             "confidence = confidence_of(int(candidates[best]))",
             "confidence = confidence_of(p)",
             "Eq. 11 of the pixel's own window assigned in place of N_best's"),
    # -- NP's Eq. 2 table (filltable.py) ----------------------------------------------
    Mutation("ft-self-term", "np", FILLTABLE,
             "w_si_mv[one] = self_mv[p]",
             "w_si_mv[one] = 0.0",
             "Eq. 2's expanded square without the target's self term s_p"),
    Mutation("ft-square-kept", "np", FILLTABLE,
             "np.add(sr, np.multiply(r, r) @ square_weights, sr)",
             "np.add(sr, r @ square_weights, sr)",
             "Eq. 2's range term with R_q in place of R_q² (the shortlist's kept candidates)"),
    Mutation("ft-square-one", "np", FILLTABLE,
             "sr = sr + float(multiply(square_weights, r, square).dot(r))",
             "sr = sr + float(square_weights.dot(r))",
             "Eq. 2's range term with R_q in place of R_q² (a lone candidate's distance)"),
    Mutation("ft-set-offsets", "np", FILLTABLE,
             "rows = -((a - h) * self.shape[1] + (b - h)) * width",
             "rows = -((a - h) * self.shape[1] + (h - b)) * width",
             "a synthesized range written into the rows mirrored left to right"),
    Mutation("np-lone-path", "np", NP, "if candidates.size == 1:  # the best match",
             "if candidates.size <= 2:  # the best match",
             "NP's one-candidate shortcut taken with two candidates (no Eq. 4 between them)"),
    Mutation("ft-lone-distance", "np", FILLTABLE, "single_mv[0] = best",
             "single_mv[0] = scale * best",
             "a lone survivor returned with the bound in place of its distance"),
    Mutation("ft-lone-sums", "np", FILLTABLE, "last[0], last[1] = row, ab_single",
             "last[0] = row",
             "a lone survivor's offset copy read from the previous step's sums"),
    Mutation("ft-shift-b-weights", "np", FILLTABLE,
             "-g * WEIGHT_UNIT, g * WEIGHT_UNIT, [0.0]",
             "g * WEIGHT_UNIT, g * WEIGHT_UNIT, [0.0]",
             "the offset copy's b formed with R_p + R_q instead of R_p - R_q"),
    # -- the fill order (Eqs. 10-12) --------------------------------------------------
    Mutation("pr-clip-d", "priority", PRIORITY,
             "return c * np.maximum(d, 0.0) + block[..., _EDGE]",
             "return c * d + block[..., _EDGE]", "Eq. 10 without max(D, 0)"),
    Mutation("pr-count", "priority", PRIORITY, "c = block[..., _CONF] / block[..., _COUNT]",
             "c = block[..., _CONF]", "Eq. 11 without |N_p|"),
    Mutation("pr-isophote", "priority", PRIORITY,
             "flow = g_row * m_col - g_col * m_row",
             "flow = g_row * m_row + g_col * m_col",
             "Eq. 12 with the gradient in place of the isophote"),
    Mutation("pr-tier", "priority", PRIORITY, "tiered = use_edges and edges_last",
             "tiered = False", "edge pixels not filled last"),
    Mutation("pr-template-index", "priority", PRIORITY,
             "t[3][1 : n + 1, 2 : n + 1, _DCOL] = 1.0", "t[3][1 : n + 1, 1:n, _DCOL] = 1.0",
             "a running-sum template off by one column"),
    Mutation("pr-pair-sign", "priority", PRIORITY, "c_mv[3], c_mv[4] = (r[p + 1] - value, 1.0)",
             "c_mv[3], c_mv[4] = (value - r[p + 1], 1.0)", "a range difference's sign swapped"),
    Mutation("pr-stale", "priority", FRONTQUEUE,
             "if keys[slot] == maxima[b]:  # the bound is the block's maximum",
             "if True:  # the bound is the block's maximum",
             "stale queue entries accepted (a block's loose bound trusted)"),
    Mutation("fq-bound-raise", "priority", FRONTQUEUE,
             "np.maximum.at(self.maxima, blocks, keys)",
             "np.minimum.at(self.maxima, blocks, keys)",
             "a raised key's block bound not raised"),
    Mutation("pr-edge-window", "priority", PRIORITY,
             "edge = box_sum(edge_pad, n, out=state[..., _EDGE])",
             "edge = box_sum(edge_pad, 3, out=state[..., _EDGE])",
             "E counted on 3×3 instead of N_p"),
    Mutation("fq-bulk-low", "priority", FRONTQUEUE,
             "self.maxima[touched] = self.blocks[touched].max(axis=1)",
             "self.maxima[touched] = self.blocks[touched].min(axis=1)",
             "a set of many slots bounds each block by its smallest key (below its maximum)"),
    Mutation("fq-bulk-stale", "priority", FRONTQUEUE,
             "self.maxima[touched] = self.blocks[touched].max(axis=1)",
             "self.maxima[touched] = np.maximum(self.maxima[touched], "
             "self.blocks[touched].max(axis=1))",
             "a set of many slots never lowers a block's bound",
             equivalent="since 0.8.3 a block's bound may be above its maximum (pop tightens a "
                        "loose bound before it trusts it), so a bound left high is the same "
                        "queue"),
    Mutation("pr-front", "priority", PRIORITY,
             "front = state[..., _NEIGH] > 0",
             "front = state[..., _NEIGH] > 1",
             "the initial front needs two filled neighbours"),
    Mutation("pr-onion-keys", "priority", ONION,
             "return unknown[np.lexsort((tie, layer.ravel()[unknown]))]",
             "return unknown[np.lexsort((layer.ravel()[unknown], tie))]",
             "the onion order's keys swapped"),
    # the same terms in the per-step path (FillFront.fill_step), and the queue's own risks
    Mutation("pr-clip-d-step", "priority", PRIORITY, "maximum(flow, zero, out=flow)",
             "pass", "Eq. 10 without max(D, 0) when the front is re-prioritised"),
    Mutation("pr-isophote-step", "priority", PRIORITY,
             "subtract(left, right, pair)",
             "add(left, right, pair)",
             "Eq. 12's isophote · normal with a + when the front is re-prioritised"),
    Mutation("pr-front-step", "priority", PRIORITY,
             "where(on, block_keys, absent)",
             "where(self.open.ravel().take(pixels), block_keys, absent)",
             "voxels off the front queued when the front is re-prioritised"),
    Mutation("fq-tie-block", "priority", FRONTQUEUE, "b = int(self.maxima.argmax())",
             "b = int(self.maxima.size - 1 - self.maxima[::-1].argmax())",
             "equal keys in different blocks: the largest tie rank first"),
    Mutation("fq-tie-row", "priority", FRONTQUEUE, "slot = start + int(row.argmax())",
             "slot = start + int(row.size - 1 - row[::-1].argmax())",
             "equal keys in one block: the largest tie rank first"),
    # -- BP (Eqs. 6-9) ----------------------------------------------------------------
    Mutation("bp-own-message", "bp", MESSAGES, "h_fwd = belief[a[idx]] - messages[rows + e]",
             "h_fwd = belief[a[idx]]", "the receiver's own message not left out"),
    Mutation("bp-normalise", "bp", MESSAGES, "m -= _row_max(m)",
             "m -= 0.0 * _row_max(m)", "max-product messages not normalised"),
    Mutation("bp-send-axis", "bp", MESSAGES,
             "rows = psi_block[:, label, :] if axis == 1 else psi_block[:, :, label]",
             "rows = psi_block[:, :, label] if axis == 1 else psi_block[:, label, :]",
             "the sender's labels on the wrong axis"),
    Mutation("bp-map-argmin", "bp", BP, "best = np.argmax(belief, axis=1)",
             "best = np.argmin(belief, axis=1)", "Eq. 8's argmax replaced by argmin"),
    Mutation("bp-pool-span", "bp", BP,
             "same = np.abs(cand_q - cand_q[index, best][:, None]) <= VALUE_TOLERANCE * 2.0"
             "**RANGE_BITS",
             "same = np.abs(cand_q - cand_q[index, best][:, None]) <= VALUE_TOLERANCE",
             "the confidence's pooling tolerance without the span"),
    Mutation("bp-silent-receivers", "bp", MESSAGES, "sends &= ~np.asarray(silent, dtype=bool)[src]",
             "sends &= ~np.asarray(silent, dtype=bool)[dst]",
             "the edge rule silences receivers instead of senders"),
    Mutation("bp-unstable-rank", "bp", BP_RANKING,
             "at = starts[:, None] + stable_smallest(packed, count)",
             "at = starts[:, None] + np.argsort(packed, axis=1)[:, :count]",
             "ties ranked by an unstable sort"),
    Mutation("bp-phi-sigma", "bp", BP, "unary = phi(dist, sigma_i)", "unary = phi(dist, sigma_s)",
             "Eq. 7 with σ_s in place of σ_i"),
    Mutation("bp-tile-measured", "bp", BP_SEARCH,
             "ur, uc = np.nonzero(known[t0 : top + bh, l0 : left + bw])",
             "ur, uc = np.nonzero(np.ones_like(known[t0 : top + bh, l0 : left + bw]))",
             "the tile search's candidates not restricted to measured pixels"),
    Mutation("bp-radii-disc", "bp", BP_SEARCH,
             "measured &= square[None, :] <= own[0][:, None]",
             "measured &= square[None, :] < own[0][:, None]",
             "the one-pass search's own discs without their rim (gap radius)"),
    Mutation("bp-radii-prior", "bp", BP_SEARCH,
             "own = (squared, proximities / (radii * radii), proximities != 0)",
             "own = (squared, proximities / (reach * reach), proximities != 0)",
             "the one-pass search's prior by the disc cut at the image, not r"),
    Mutation("bp-radii-short", "bp", BP_SEARCH, "        take = enough\n",
             "        take = enough | True\n",
             "the one-pass search keeps discs short of k candidates (no widening)"),
    Mutation("bp-skip-receivers", "bp", MESSAGES, "dirty_mask[dst[changed]] = True",
             "dirty_mask[src[changed]] = True",
             "after a sweep, the senders of changed messages re-read instead of the receivers"),
    Mutation("bp-skip-again", "bp", MESSAGES, "again = dirty_mask[src]",
             "again = dirty_mask[dst]",
             "the edges re-sent are those into the changed nodes, not out of them"),
    # -- registration (Eqs. 14-21) ----------------------------------------------------
    Mutation("reg-gn-sign", "registration", f"{REG}/translation.py", "rhs = -(columns @ e)",
             "rhs = (columns @ e)", "Eq. 17's right-hand side without its minus"),
    Mutation("reg-gn-update", "registration", f"{REG}/translation.py", "t = t + delta",
             "t = t - delta", "the Gauss-Newton update subtracted"),
    Mutation("reg-hat-args", "registration", f"{REG}/mosaicking.py",
             "wy = 1.0 - np.abs(y - height / 2) / (height / 2)",
             "wy = 1.0 - np.abs(y - width / 2) / (height / 2)", "Eq. 18 with w for h"),
    Mutation("reg-fit-swap", "registration", f"{REG}/warp.py",
             'b, beta = fit_line(laser[:, 1], camera[:, 1], "h")',
             'b, beta = fit_line(camera[:, 1], laser[:, 1], "h")',
             "Eq. 21's v-line fitted the wrong way round"),
    Mutation("reg-eq20-index", "registration", f"{REG}/warp.py",
             "rho = r * focal / np.hypot(focal, laser[:, 1])",
             "rho = r * focal / np.hypot(focal, laser[:, 0])", "Eq. 20's ρ from φ instead of h"),
    Mutation("reg-eq14-args", "registration", f"{REG}/cylinder.py",
             "return focal * np.arctan2(x, focal), focal * y / np.hypot(x, focal)",
             "return focal * np.arctan2(focal, x), focal * y / np.hypot(x, focal)",
             "Eq. 14's arctan arguments swapped"),
    Mutation("reg-eq19-tan", "registration", f"{REG}/range_image.py",
             "np.asarray(focal / np.tan(theta))", "np.asarray(focal * np.tan(theta))",
             "Eq. 19's f / tan θ as f · tan θ"),
    # -- BP as printed (refsynth/synthesis/belief/reference.py) ---------------------------
    Mutation("bpref-eq7-sign", "bp-reference", BELIEF_REF,
             "return -distance / (2.0 * sigma_i * sigma_i)",
             "return distance / (2.0 * sigma_i * sigma_i)", "Eq. 7's sign"),
    Mutation("bpref-eq7-sigma", "bp-reference", BELIEF_REF,
             "return -distance / (2.0 * sigma_i * sigma_i)",
             "return -distance / (2.0 * sigma_i)", "Eq. 7's σ_i² as σ_i"),
    Mutation("bpref-eq6-mean", "bp-reference", BELIEF_REF,
             "return (int(np.sum(d * d)) * 2.0 ** (-2 * RANGE_BITS)) / count",
             "return (int(np.sum(d * d)) * 2.0 ** (-2 * RANGE_BITS)) / a.size",
             "Eq. 6's mean over the whole overlap, not the pixels where both have range"),
    Mutation("bpref-message-subtraction", "bp-reference", BELIEF_REF,
             "new[e] = send(psi[e], belief[a] - messages[E + e], 0, product)",
             "new[e] = send(psi[e], belief[a] - messages[e], 0, product)",
             "Eq. 9's message i→j: the sender's belief less its own outgoing message"),
    Mutation("bpref-message-whole-belief", "bp-reference", BELIEF_REF,
             "new[E + e] = send(psi[e], belief[b] - messages[e], 1, product)",
             "new[E + e] = send(psi[e], belief[b], 1, product)",
             "Eq. 9's message j→i from the sender's whole belief (j's message not taken out)"),
    Mutation("bpref-belief-order", "bp-reference", BELIEF_REF,
             "for q in ((r, c - 1), (r - 1, c), (r, c + 1), (r + 1, c))",
             "for q in ((r, c - 1), (r, c + 1), (r - 1, c), (r + 1, c))",
             "a belief's incoming messages summed left, right, up, down (not left, up, …)"),
    Mutation("bpref-belief-first-two", "bp-reference", BELIEF_REF,
             "for q in ((r, c - 1), (r - 1, c), (r, c + 1), (r + 1, c))",
             "for q in ((r - 1, c), (r, c - 1), (r, c + 1), (r + 1, c))",
             "a belief's first two incoming messages swapped (up, left, right, down)",
             equivalent="the sum starts at 0.0 and 0.0 + a is a exactly, so (0 + a) + b and "
                        "(0 + b) + a are both the one rounding of a + b: only the third "
                        "and fourth terms' places can change a bit"),
    Mutation("bpref-normalise-kept", "bp-reference", BELIEF_REF,
             "        return m - m.max()\n", "        return m\n",
             "a max-product message not normalised"),
    Mutation("bpref-confidence-clip", "bp-reference", BELIEF_REF,
             "min(float(left_to_right_sum(np.where(same, p, 0.0))), 1.0)",
             "float(left_to_right_sum(np.where(same, p, 0.0)))",
             "the confidence not clipped to 1"),
    Mutation("bpref-confidence-numpy-sum", "bp-reference", BELIEF_REF,
             "p = p / left_to_right_sum(p)", "p = p / np.sum(p)",
             "the confidence normalised by numpy's pairwise sum, not left to right"),
    Mutation("bpref-ranking-tie", "bp-reference", BELIEF_REF,
             "ranked = sorted(range(len(dist)), key=lambda i: (dist[i], i))[:kk]",
             "ranked = sorted(range(len(dist)), key=lambda i: (dist[i], -i))[:kk]",
             "equal distances ranked by the last offset in the disc, not the first"),
    # -- the oracle's literal reference (refsynth/synthesis/reference.py) -----------------
    Mutation("oref-eq5-threshold", "oracle-reference", ORACLE_REFERENCE,
             "threshold = (1.0 + epsilon) * distances[best]",
             "threshold = distances[best] + epsilon",
             "Eq. 5's threshold (1 + ε) d_best as d_best + ε"),
    Mutation("oref-eq5-strict", "oracle-reference", ORACLE_REFERENCE,
             "members = [i for i, d in enumerate(distances) if d <= threshold]",
             "members = [i for i, d in enumerate(distances) if d < threshold] or [best]",
             "Eq. 5's ≤ as <"),
    Mutation("oref-eq4-last", "oracle-reference", ORACLE_REFERENCE,
             "best = distances.index(min(distances))",
             "best = len(distances) - 1 - distances[::-1].index(min(distances))",
             "Eq. 4's tie: the last minimum, not the first"),
    Mutation("oref-eq11-update", "oracle-reference", ORACLE_REFERENCE,
             "c_best = confidence_term(conf, *candidates[best], n)",
             "c_best = confidence_term(conf, *source, n)",
             "Eq. 11's update from the drawn member's window, not N_best's"),
    Mutation("oref-eq10-sum", "oracle-reference", ORACLE_REFERENCE,
             "P = C * max(D, 0.0) + E", "P = C * max(D, 0.0) * E",
             "Eq. 10's sum of the terms as a product"),
    Mutation("oref-eq12-order", "oracle-reference", ORACLE_REFERENCE,
             "d_term = 1.0 - abs(g_row * m_col - g_col * m_row) / norm",
             "d_term = 1.0 - abs(g_row * (m_col / norm) - g_col * (m_row / norm))",
             "Eq. 12's front normal normalised before the cross product (an ulp)"),
    Mutation("oref-bp-confidence-clip", "oracle-reference", ORACLE_REFERENCE,
             "confidence[r, c] = min(pooled, 1.0)", "confidence[r, c] = pooled",
             "BP's confidence not clipped to 1"),
    Mutation("oref-bp-confidence-sum", "oracle-reference", ORACLE_REFERENCE,
             "pooled += weights[label] / z", "pooled += weights[label] / float(np.sum(weights))",
             "BP's confidence normalised by numpy's pairwise sum, not left to right"),
    Mutation("oref-bp-lift", "oracle-reference", ORACLE_REFERENCE,
             "both = (a != NO_RANGE) & (b != NO_RANGE)",
             "both = (a + int(shifts[0]) >= 0) & (b + int(shifts[1]) >= 0) & (a != NO_RANGE)"
             " & (b != NO_RANGE)",
             "a shifted label's range below 0 read as missing in Eq. 6 (no lift)"),
    Mutation("oref-bp-message", "oracle-reference", ORACLE_REFERENCE,
             "new[e] = _send(log_psi[e] + (belief[a] - messages[E + e])[:, None], 0, product)",
             "new[e] = _send(log_psi[e] + belief[a][:, None], 0, product)",
             "BP's message i→j from the sender's whole belief (j's message not taken out)"),
    Mutation("oref-offset-clip", "oracle-reference", ORACLE_REFERENCE,
             "frame.span * 2.0**-RANGE_BITS)), float(low)), float(high))",
             "frame.span * 2.0**-RANGE_BITS)), -np.inf), np.inf)",
             "the offset copy's value not clipped to the measured range"),
    Mutation("cascade-no-doubling", "completion", COMPLETION, "min(2 * most, max_sweeps)",
             "min(most, max_sweeps)",
             "the cascade's coarser levels given the finest level's sweeps, not twice as many"),
    Mutation("cascade-no-put-back", "completion", COMPLETION,
             "start = np.where(known, range_values, start)", "start = start",
             "a level's start keeps the coarse solution at the measured pixels"),
    Mutation("cascade-block-count", "completion", COMPLETION,
             "count[cells] = count[cells] + inside", "count[cells] = count[cells] + 1.0",
             "the coarse range's block mean divided by four, not by its measured pixels"),
    # -- NP's literal reference: its tests must catch a wrong step as well ------------
    Mutation("npref-eq5-strict", "np-reference", NP_REFERENCE,
             "members = [i for i, d in enumerate(distances) if d <= threshold]",
             "members = [i for i, d in enumerate(distances) if d < threshold] or [best]",
             "Eq. 5 with < (the set keeps only strictly nearer matches)"),
    Mutation("npref-eq4-last", "np-reference", NP_REFERENCE,
             "best = distances.index(min(distances))",
             "best = len(distances) - 1 - distances[::-1].index(min(distances))",
             "Eq. 4's tie to the last minimum, not the first"),
    Mutation("npref-draw-first", "np-reference", NP_REFERENCE,
             "source = candidates[members[int(draws[step] * len(members))]]",
             "source = candidates[members[0]]", "Eq. 5's draw replaced by its first member"),
    Mutation("npref-confidence-own", "np-reference", NP_REFERENCE,
             'new = c_best if confidence_update == "best" else',
             'new = c_best if confidence_update != "best" else',
             "the two readings of Eq. 11's update swapped"),
    Mutation("npref-eq11-count", "np-reference", NP_REFERENCE,
             "return float(conf[rows, cols].sum()) / count",
             "return float(conf[rows, cols].sum()) / (n * n)",
             "Eq. 11's |N_p| counts the voxels off the image too"),
    Mutation("npref-d-unclipped", "np-reference", NP_REFERENCE,
             "return C * max(D, 0.0) + e_term", "return C * D + e_term",
             "Eq. 10 with a negative data term"),
    Mutation("npref-tier-dropped", "np-reference", NP_REFERENCE,
             "tier = int(use_edges and edges_last and bool(edges[r, c]))", "tier = 0",
             "edge voxels not deferred to the end"),
    Mutation("npref-tie-reversed", "np-reference", NP_REFERENCE,
             "if key is None or (tier, -P, int(tie[r, c])) < key:",
             "if key is None or (tier, -P, -int(tie[r, c])) < key:",
             "equal priorities taken by the largest tie number"),
    Mutation("npref-widened-d-only", "np-reference", NP_REFERENCE,
             "if d <= min(dist) + radius]", "if d <= min(dist)]",
             "the widened search keeps the nearest filled voxels only"),
    Mutation("npref-offset-slack", "np-reference", NP_REFERENCE,
             "abs(a * d - b) > OFFSET_SLACK * a", "abs(a * d - b) > 2 * OFFSET_SLACK * a",
             "the offset copy's agreement twice as loose"),
    Mutation("npref-eq12-sides", "np-reference", NP_REFERENCE,
             "D = 1.0 - abs(g_row * m_col - g_col * m_row) / norm",
             "D = 1.0 - abs(g_row * m_row - g_col * m_col) / norm",
             "Eq. 12 with the isophote along the gradient, not turned by 90°"),
]


def _copy_project(target: Path) -> None:
    """A plain copy of what the tests need: the package, the tests, the project files."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".hypothesis", ".pytest_cache")
    for name in ("refsynth", "tests"):
        shutil.copytree(ROOT / name, target / name, ignore=ignore)
    for name in ("pyproject.toml", "setup.cfg", "pytest.ini", "conftest.py", "README.md"):
        if (ROOT / name).is_file():
            shutil.copy2(ROOT / name, target / name)


def _run_tests(copy: Path, tests: list[str], timeout: float) -> tuple[bool, str, float]:
    """``pytest -x -q`` on the tests in the copy: (all passed, the first failure, seconds)."""
    tests = [t for t in tests if (copy / t.split("::")[0]).exists()]  # e.g. a gaps file
    env = dict(os.environ, PYTHONPATH=str(copy), PYTHONDONTWRITEBYTECODE="1")
    env.pop("PYTEST_ADDOPTS", None)
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests],
            cwd=copy, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, f"timeout after {timeout:.0f} s", time.perf_counter() - start
    seconds = time.perf_counter() - start
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", done.stdout, flags=re.M)
    if done.returncode == 0:
        return True, "", seconds
    return False, failed[0] if failed else f"pytest exit {done.returncode}", seconds


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="+", metavar="ID", help="only these mutations")
    parser.add_argument("--list", action="store_true", help="list the mutations and exit")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per test run")
    parser.add_argument("--keep", action="store_true", help="keep the temporary copy")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.only or m.id in args.only]
    if args.list:
        for m in chosen:
            print(f"{m.id:22s} {m.area:12s} {m.file}: {m.what}")
        return 0
    unknown = set(args.only or ()) - {m.id for m in MUTATIONS}
    if unknown:
        parser.error(f"unknown mutation(s): {', '.join(sorted(unknown))}")
    work = Path(tempfile.mkdtemp(prefix="refsynth-mutants-"))
    copy = work / "project"
    _copy_project(copy)
    print(f"copy of {ROOT} in {copy}", flush=True)
    results = []
    try:
        for area in sorted({m.area for m in chosen}):   # the unmutated copy must pass
            ok, failure, seconds = _run_tests(copy, TESTS[area], args.timeout)
            print(f"baseline {area:12s} {'pass' if ok else 'FAIL ' + failure} ({seconds:.0f} s)",
                  flush=True)
            if not ok:
                print("the unmutated tests fail: fix that first", file=sys.stderr)
                return 2
        for m in chosen:
            path = copy / m.file
            source = path.read_text()
            count = source.count(m.original)
            if count != 1:
                state = "not found" if count == 0 else f"found {count} times"
                print(f"SKIP     {m.id:22s} the original line is {state} in {m.file}",
                      flush=True)
                results.append((m, "skipped", state, 0.0))
                continue
            path.write_text(source.replace(m.original, m.replacement))
            try:
                ok, failure, seconds = _run_tests(copy, TESTS[m.area], args.timeout)
            finally:
                path.write_text(source)
            state = "survived" if ok else "killed"
            print(f"{state.upper():8s} {m.id:22s} {m.what}" + (f"  [{failure}]" if failure else "")
                  + f" ({seconds:.0f} s)", flush=True)
            results.append((m, state, failure, seconds))
    finally:
        if args.keep:
            print(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    applied = [r for r in results if r[1] != "skipped"]
    killed = [r for r in applied if r[1] == "killed"]
    survivors = [r for r in applied if r[1] == "survived"]
    equivalent = [r for r in survivors if r[0].equivalent]
    gaps = [r for r in survivors if not r[0].equivalent]
    flagged = [r for r in applied if r[0].equivalent and r[1] == "killed"]
    non_equivalent = [r for r in applied if not r[0].equivalent]
    print()
    print(f"{len(killed)} killed, {len(survivors)} survived, "
          f"{len(results) - len(applied)} skipped, of {len(results)} mutations")
    print(f"non-equivalent mutations killed: {len(non_equivalent) - len(gaps)} of "
          f"{len(non_equivalent)}; of the seven of issue #11: "
          f"{sum(1 for r in killed if r[0].issue)} of {sum(1 for r in applied if r[0].issue)}")
    for m, _, _, _ in equivalent:
        print(f"  survived, equivalent: {m.id}: {m.equivalent}")
    for m, _, _, _ in gaps:
        print(f"  SURVIVED, not equivalent (a gap in the tests): {m.id}: {m.what}")
    for m, _, failure, _ in flagged:
        print(f"  killed although listed as equivalent: {m.id} [{failure}]")
    return 1 if gaps else 0


if __name__ == "__main__":
    sys.exit(main())
