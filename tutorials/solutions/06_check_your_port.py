"""Solutions to the exercises of tutorial 6 (check your own port against the oracle).

Run as ``python tutorials/solutions/06_check_your_port.py``; the test suite runs it too.
Each exercise prints its findings and asserts the claims its answer makes, so a change in
refsynth that breaks an answer fails a test.
"""

import tempfile
from fractions import Fraction
from pathlib import Path

import numpy as np
from scipy import ndimage

from refsynth.numeric import NO_RANGE, on_confidence_grid
from refsynth.oracle import build_cases, check_function, export_cases, load_case
from refsynth.oracle.cases import select_cases
from refsynth.oracle.runs import run_outputs
from refsynth.synthesis.reference import (
    confidence_term,
    disc_offsets,
    eq2_distance,
    priority_terms,
)

CASES = Path(tempfile.mkdtemp(prefix="refsynth-oracle-")) / "cases"
export_cases(CASES, select_cases(build_cases(), ["np-8x8-*", "np-12x10-*", "bp-8x8-noise"]))


def offset_shift(q_pad, p, source, window):
    """Exercise 1b: the windows' consistent range difference Δ (0 when not taken)."""
    (r, c), (a, b), n = p, source, window.shape[0]
    total = weighted = 0
    deltas = []
    for i in range(n):
        for j in range(n):
            x, y = int(q_pad[r + i, c + j]), int(q_pad[a + i, b + j])
            if x != NO_RANGE and y != NO_RANGE:
                total, weighted = total + int(window[i, j]), weighted + int(window[i, j]) * (x - y)
                deltas.append(x - y)
    if total == 0 or any(abs(total * d - weighted) > 2**9 * total for d in deltas):
        return 0
    return round(Fraction(weighted, total))   # Fraction rounds half to even


def port(inputs, options, confidence_rule="product", offset=False):
    """Tutorial 6's fixed port, with the onion order (exercise 1), a confidence rule and the
    offset copy (exercise 1b)."""
    if options["method"] != "np":
        return None
    qi, q = inputs["q_intensity"], inputs["q_range"].copy()
    n, radius, eps = options["neighbourhood"], options["radius"], options.get("epsilon", 0.1)
    h, (H, W) = n // 2, q.shape
    edges = inputs["edges"] & options["use_edges"]
    qi_pad = np.pad(qi, ((h, h), (h, h), (0, 0)), mode="symmetric")
    q_pad = np.pad(q, h, constant_values=NO_RANGE)
    filled, out = q != NO_RANGE, inputs["partial_range"].copy()
    low, high = float(np.nanmin(out)), float(np.nanmax(out))
    span = high - low if high > low else 1.0
    conf = filled.astype(float)
    onion = options.get("ordering", "priority") == "onion"
    if onion:   # exercise 1: layer by layer, ties by the prepared permutation
        layer = ndimage.distance_transform_cdt(~filled, metric="chessboard")
        unknown = np.argwhere(~filled)            # raster order
        keys = [(layer[r, c], inputs["onion_tie"][i]) for i, (r, c) in enumerate(unknown)]
        schedule = [tuple(unknown[i]) for i in sorted(range(len(unknown)), key=keys.__getitem__)]

    def patch(r, c):
        return qi_pad[r:r + n, c:c + n], q_pad[r:r + n, c:c + n]

    def next_pixel():
        key, p = None, None
        for r in range(H):
            for c in range(W):
                if filled[r, c] or not filled[max(r - 1, 0):r + 2, max(c - 1, 0):c + 2].any():
                    continue
                e = int(edges[max(r - h, 0):r + h + 1, max(c - h, 0):c + h + 1].sum())
                C, D, Et = priority_terms(r, c, filled, q, conf,
                                          e if options["use_edges"] else None, n,
                                          use_isophotes=options.get("use_isophotes", True))
                k = (int(edges[r, c]), -(C * max(D, 0.0) + Et), int(inputs["tie"][r, c]))
                if key is None or k < key:
                    key, p = k, (r, c)
        return p

    order, sources, confidences = [], [], []
    for step in range(int((~filled).sum())):
        r, c = schedule[step] if onion else next_pixel()
        cands = [(r + a, c + b) for a, b in disc_offsets(radius)
                 if 0 <= r + a < H and 0 <= c + b < W and filled[r + a, c + b]]
        d = [eq2_distance(*patch(r, c), *patch(a, b), inputs["window"],
                          options.get("range_weight", 1.0), options.get("missing_range", "mean"))
             for a, b in cands]
        best = d.index(min(d))
        members = [i for i, x in enumerate(d) if x <= (1.0 + eps) * d[best]]
        source = cands[members[int(inputs["draws"][step] * len(members))]]
        c_best = confidence_term(conf, *cands[best], n)
        new = c_best if confidence_rule == "best" else confidence_term(conf, r, c, n) * c_best
        value, copied = int(q[source]), out[source]
        if offset:   # exercise 1b: shift the drawn value, clip to the span (both units)
            shifted = min(max(value + offset_shift(q_pad, (r, c), source, inputs["window"]),
                              0), 2**16)
            if shifted != value:
                copied = min(max(float(copied + (shifted - value) * (span * 2.0**-16)), low),
                             high)
                value = shifted
        filled[r, c], q[r, c], out[r, c] = True, value, copied
        q_pad[r + h, c + h] = value
        conf[r, c] = on_confidence_grid(new)
        order.append((r, c))
        sources.append(source)
        confidences.append(conf[r, c])
    return dict(range=out, confidence=conf, order=np.array(order), step_pixel=np.array(order),
                step_source=np.array(sources), step_confidence=np.array(confidences))


def exercise_1() -> None:
    """Teach the port the onion order.

    The onion order (Fig. 7) is fixed before the fill: each unknown pixel's layer is its
    chessboard distance to the known range, and within a layer the prepared ``onion_tie``
    orders the unknown pixels (taken in raster order). With it the port passes the onion
    cases too, which also use ``missing_range="ignore"`` (Eq. 2 as written).
    """
    for name in ("np-8x8-ramp", "np-12x10-ramp"):
        report = check_function(port, CASES, case=name)
        print(f"exercise 1, {name}: {report}")
        assert report.passed
    report = check_function(port, CASES)
    print(f"exercise 1, every exported case: {report}")
    assert report.passed and len(report.checked) == 6


def exercise_2() -> None:
    """Plant the dropped-factor bug and predict where the oracle reports it.

    With ``C(best)`` alone, a pixel's confidence differs from ``C(p) · C(best)`` exactly when
    ``C(p)`` (Eq. 11, ``step_C`` in the golden trace) is below 1: the first such step is the
    one reported, and the array is ``step_confidence`` (the wrong value does not change that
    step's own choices; it changes later priorities, at later steps). That is always step 0:
    ``N_p`` holds ``p`` itself, unknown, with confidence 0, so ``C(p) < 1`` at every step.
    """
    golden = load_case(CASES, "np-8x8-noise")[1]
    assert np.all(golden["step_C"] < 1.0)
    predicted = int(np.flatnonzero(golden["step_C"] < 1.0)[0])
    report = check_function(lambda i, o: port(i, o, "best"), CASES, case="np-8x8-noise")
    print(f"exercise 2: predicted step {predicted}; {report}")
    assert report.mismatch.key == "step_confidence" and report.mismatch.step == predicted


def exercise_3() -> None:
    """A BP "port" with sum instead of max: the oracle names sweep 1's messages.

    The unary terms (Eq. 7 and the measured neighbours' Eq. 6 terms) and the pairwise
    compatibilities are computed before any message, and do not depend on the product
    rule, so they agree; the first messages sent (sweep 1) already differ: log-sum-exp
    instead of max over the sender's labels.
    """
    def sum_product(inputs, options):
        options = dict(options)
        kind, seed = options.pop("method"), options.pop("seed")
        if kind != "bp":
            return None
        raw = {k: inputs[k] for k in ("intensity", "partial_range", "edges")}
        return run_outputs(kind, raw, dict(options, product="sum"), seed)

    report = check_function(sum_product, CASES, case="bp-8x8-noise")
    print(f"exercise 3: {report}")
    assert report.mismatch.key == "sweep_messages" and report.mismatch.step == 1


def exercise_1b() -> None:
    """The offset copy: after the draw, shift the value by the windows' range difference.

    NP's default (``range_copy="offset"``) writes the drawn value shifted by the
    weighted mean difference between the two windows' range where both have it, when every
    difference agrees with that mean to within ``2**9`` grid steps (``2**-7`` of the span),
    rounded half to even and clipped to the span. The port without it passes the value-copy
    twin of the slanted-plane case and fails the default one; with it, both pass.
    """
    planes = Path(tempfile.mkdtemp(prefix="refsynth-oracle-")) / "planes"
    export_cases(planes, select_cases(build_cases(), ["np-14x18-*"]))
    copying = check_function(lambda i, o: port(i, o, "best"), planes)
    print(f"exercise 1b, the value copy: {copying}")
    assert not copying.passed and copying.mismatch.case == "np-14x18-planes"
    assert check_function(lambda i, o: port(i, o, "best"), planes,
                          case="np-14x18-planes-value-copy").passed
    shifting = check_function(lambda i, o: port(i, o, "best", offset=True), planes,
                              case="np-14x18-planes")
    print(f"exercise 1b, the offset copy: {shifting}")
    assert shifting.passed


if __name__ == "__main__":
    exercise_1()
    exercise_2()
    exercise_3()
    exercise_1b()
