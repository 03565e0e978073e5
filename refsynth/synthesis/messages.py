r"""Loopy belief propagation in the log domain (§3.2.3, Eqs. 8–9; Fig. 6, step 5).

The messages of Eq. 9, on a synchronous schedule, normalised every sweep:

.. math:: M_{ij}(x_j) = Z \max_{x_i} \Psi(x_i, x_j)\, \Phi(x_i, y_i)
          \prod_{k \in N(i) \setminus j} M_{ki}(x_i)

(max-product; sum-product replaces the max by a sum), and the beliefs of Eq. 8,
``b_i(x_i) = Φ(x_i, y_i) Π_j M_ji(x_i)``, all as logarithms. The edge-constraint
rule enters as nodes that send no message (``silent``) and, in the paper's
reading, nodes that receive none either (``deaf``);
:func:`refsynth.synthesis.bp.bp_fill` builds the model (the candidates, Φ and Ψ)
and calls :func:`belief_propagation`.

The numeric contract (:mod:`refsynth.numeric`): float64 throughout;
max-product needs only ``+ − max``, whose results do not depend on any order but
that of the additions, which is fixed: a node's incoming messages are added slot
by slot in the order left, up, right, down; sum-product's log-sum-exp uses
:func:`~refsynth.numeric.portable_exp`, :func:`~refsynth.numeric.portable_log`
and left-to-right sums over the labels.

References
----------
Torres-Méndez & Dudek (2008), §3.2.3, Eqs. 8–9, Fig. 6, doi:10.1007/s11263-007-0108-2.
J. S. Yedidia, W. T. Freeman and Y. Weiss, "Understanding belief propagation and its
generalizations", in *Exploring Artificial Intelligence in the New Millennium* (2003).
"""

from __future__ import annotations

import numpy as np

from refsynth.numeric import left_to_right_sum, portable_exp, portable_log

__all__ = ["belief_propagation"]

_CHUNK_FLOATS = 1 << 24  # about 128 MB of float64 per temporary block


def belief_propagation(
    unary: np.ndarray,
    pairs: np.ndarray,
    log_psi: np.ndarray,
    *,
    silent: np.ndarray | None = None,
    deaf: np.ndarray | None = None,
    iterations: int = 50,
    tolerance: float = 1e-4,
    product: str = "max",
    damping: float = 0.0,
    return_messages: bool = False,
):
    """Synchronous loopy BP in the log domain (Eq. 9); returns beliefs (Eq. 8).

    Parameters
    ----------
    unary : ndarray of shape (N, K)
        ``log Φ`` plus the terms of fixed neighbours, per node and label.
    pairs : ndarray of shape (E, 2), int
        Node indices of each undirected edge ``(a, b)``.
    log_psi : ndarray of shape (E, K, K)
        ``log Ψ[e, l, m]`` for label ``l`` at ``a`` and ``m`` at ``b``.
    silent : ndarray of shape (N,), bool, optional
        Nodes that send no message (the edge-constraint rule).
    deaf : ndarray of shape (N,), bool, optional
        Nodes that receive no message (the paper's edge rule adds the edge
        nodes here too).
    iterations : int
        At most this many synchronous sweeps.
    tolerance : float
        Stop when no message changes by more than this (log domain).
    product : {"max", "sum"}
        Max-product (MAP) or sum-product (marginals).
    damping : float in [0, 1)
        Each new message is ``(1 − damping)·new + damping·old`` (log domain);
        0 is the plain synchronous schedule.
    return_messages : bool
        Also return the final messages.

    Returns
    -------
    beliefs : ndarray of shape (N, K)
        Unnormalised log beliefs ``unary + Σ incoming messages``.
    iterations : int
        The sweeps done.
    messages : ndarray of shape (2E, K), only with ``return_messages``
        Log messages; row ``e < E`` goes from ``pairs[e, 0]`` to
        ``pairs[e, 1]``, row ``E + e`` back. Each is normalised: its maximum
        (max-product) or its log-sum-exp (sum-product) is 0; a message not
        sent is 0.

    Notes
    -----
    Everything is float64. A node's incoming messages are added one slot at a
    time in the order left, up, right, down (the order of their rows), then
    added to ``unary``; sum-product's log-sum-exp uses
    :func:`~refsynth.numeric.portable_exp`, :func:`~refsynth.numeric.portable_log`
    and left-to-right sums over the labels (the numeric contract).
    """
    n, k = unary.shape
    e = pairs.shape[0]
    a, b = pairs[:, 0], pairs[:, 1]
    # directed messages: [0, e) go a -> b, [e, 2e) go b -> a
    messages = np.zeros((2 * e + 1, k))  # the last row: "no message"
    src = np.concatenate([a, b])
    dst = np.concatenate([b, a])
    rev = np.concatenate([np.arange(e, 2 * e), np.arange(e)])
    # incoming messages of each node: up to 4 (the 4-neighbourhood), by row:
    # left (a horizontal pair's a -> b), up, right (b -> a), down
    order = np.argsort(dst, kind="stable")
    counts = np.bincount(dst, minlength=n)
    slot = np.arange(2 * e) - np.repeat(np.cumsum(counts) - counts, counts)
    incoming = np.full((n, max(int(counts.max(initial=0)), 1)), 2 * e, dtype=np.int64)
    incoming[dst[order], slot] = order
    sends = np.ones(2 * e, dtype=bool)
    if silent is not None:
        sends &= ~np.asarray(silent, dtype=bool)[src]
    if deaf is not None:
        sends &= ~np.asarray(deaf, dtype=bool)[dst]
    unary = np.asarray(unary, dtype=np.float64)
    log_psi = np.asarray(log_psi, dtype=np.float64)

    def beliefs():
        total = np.zeros((n, k))
        for column in range(incoming.shape[1]):  # left, up, right, down
            total = total + messages[incoming[:, column]]
        return unary + total

    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 - the count is returned
        h = beliefs()[src] - messages[rev]  # leave out the receiver's own message
        new = np.empty((2 * e, k))
        _send(new[:e], h[:e], log_psi, axis=1, product=product)
        _send(new[e:], h[e:], log_psi, axis=2, product=product)
        new[~sends] = 0.0
        if damping:
            new = new * (1.0 - damping) + damping * messages[:-1]
        change = float(np.max(np.abs(new - messages[:-1]), initial=0.0))
        messages[:-1] = new
        if change <= tolerance:
            break
    belief = beliefs()
    if return_messages:
        return belief, done, messages[:-1].copy()
    return belief, done


def _send(out: np.ndarray, h: np.ndarray, log_psi: np.ndarray, *, axis: int, product: str):
    """One direction of Eq. 9 for a block of edges, normalised (max or log-sum = 0)."""
    k = h.shape[1]
    chunk = max(1, _CHUNK_FLOATS // (k * k))
    for start in range(0, h.shape[0], chunk):
        sl = slice(start, start + chunk)
        if axis == 1:  # sender is the first node: its label indexes rows of psi
            t = log_psi[sl] + h[sl, :, None]
        else:
            t = log_psi[sl] + h[sl, None, :]
        if product == "max":
            m = t.max(axis=axis)
            m -= m.max(axis=1, keepdims=True)
        else:
            top = t.max(axis=axis)
            terms = portable_exp(t - np.expand_dims(top, axis))
            m = portable_log(left_to_right_sum(terms, axis=axis)) + top
            m = m - _logsumexp(m)[:, None]
        out[sl] = m


def _logsumexp(x: np.ndarray) -> np.ndarray:
    """``log Σ exp`` over the labels (axis 1), portable and left to right."""
    top = x.max(axis=1)
    return portable_log(left_to_right_sum(portable_exp(x - top[:, None]), axis=1)) + top
