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

The cost: a sweep sends only the messages whose inputs changed bit for bit in
the last one (the others would come out the same bits), so after the first
sweep the work follows the few places still settling; Ψ may be a function that
computes the rows of a block of edges, so the (E, K, K) table need not be held.
The result is that of plain synchronous sweeps over every edge, bit for bit
(``tests/test_bp_speed_memory.py`` compares the two).

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

_CHUNK_FLOATS = 1 << 22  # about 32 MB of float64 per temporary block
_PSI_CACHE = 1 << 26  # bytes of Ψ rows kept between sweeps (64 MB)


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
    log_psi : ndarray of shape (E, K, K), or callable
        ``log Ψ[e, l, m]`` for label ``l`` at ``a`` and ``m`` at ``b``; or a
        function that returns those rows, ``log_psi(edges)`` for an int array
        of edge indices (so that the whole table need not be held:
        :func:`refsynth.synthesis.bp.bp_fill` computes Ψ where it is needed).
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

    Only the messages that can change are recomputed: a message ``i → j`` is a
    function of ``i``'s unary term and of all of ``i``'s incoming messages (its
    belief, less the message from ``j``), and, with damping, of its own last
    value. When none of these changed bit for bit in the last sweep, the new
    message is the old one, bit for bit, and contributes 0 to the change; so
    after the first sweep only the edges near a changing message are sent
    (on the Motorcycle at 450×375, 35 000 of 424 000 in the second sweep and
    under 1 000 from the twelfth). A message holding a non-finite value is
    always recomputed, so that the change is the literal ``max |new − old|``.
    The messages are updated in place, an undirected edge's two messages at
    a time (each reads only the other's old value), in chunks: the memory is
    the messages and the beliefs, with no copy of either.

    Examples
    --------
    A chain of three nodes with two labels; the middle node's evidence is
    neutral, its neighbours pull it to label 0 through an agreeing Ψ:

    >>> unary = np.log(np.array([[0.9, 0.1], [0.5, 0.5], [0.8, 0.2]]))
    >>> pairs = np.array([[0, 1], [1, 2]])
    >>> log_psi = np.log(np.array([[[0.9, 0.1], [0.1, 0.9]]] * 2))
    >>> beliefs, sweeps = belief_propagation(unary, pairs, log_psi)
    >>> np.argmax(beliefs, axis=1).tolist(), sweeps
    ([0, 0, 0], 3)
    """
    n, k = unary.shape
    e = pairs.shape[0]
    a, b = pairs[:, 0], pairs[:, 1]
    # directed messages: [0, e) go a -> b, [e, 2e) go b -> a
    messages = np.zeros((2 * e + 1, k))  # the last row: "no message"
    src = np.concatenate([a, b])
    dst = np.concatenate([b, a])
    # incoming messages of each node: up to 4 (the 4-neighbourhood), by row:
    # left (a horizontal pair's a -> b), up, right (b -> a), down
    order = np.argsort(dst, kind="stable")
    counts = np.bincount(dst, minlength=n)
    slot = np.arange(2 * e) - np.repeat(np.cumsum(counts) - counts, counts)
    incoming = np.full((n, max(int(counts.max(initial=0)), 1)), 2 * e, dtype=np.int64)
    incoming[dst[order], slot] = order
    del order, slot, counts
    sends = np.ones(2 * e, dtype=bool)
    if silent is not None:
        sends &= ~np.asarray(silent, dtype=bool)[src]
    if deaf is not None:
        sends &= ~np.asarray(deaf, dtype=bool)[dst]
    unary = np.asarray(unary, dtype=np.float64)
    log_psi = _PsiRows(log_psi, k)
    belief = np.empty((n, k))
    unfinite = np.zeros(2 * e, dtype=bool)  # messages holding a non-finite value
    chunk = max(1, _CHUNK_FLOATS // (k * k))

    def update_beliefs(nodes):
        """``unary + Σ incoming`` (left, up, right, down) of ``nodes`` (a slice or indices)."""
        rows = incoming[nodes]
        total = np.zeros((rows.shape[0], k))
        for column in range(incoming.shape[1]):  # left, up, right, down
            total = total + messages[rows[:, column]]
        belief[nodes] = unary[nodes] + total

    # iteration 1: every node's belief, every edge sent
    dirty = None  # None: all nodes
    active = None  # None: all edges
    done = 0
    for done in range(1, iterations + 1):  # noqa: B007 - the count is returned
        if dirty is None:
            for start in range(0, n, chunk):
                update_beliefs(slice(start, start + chunk))
        elif dirty.size:
            for start in range(0, dirty.size, chunk):
                update_beliefs(dirty[start : start + chunk])
        if active is not None:
            log_psi.keep(active)
        changed = np.zeros(2 * e, dtype=bool)  # this sweep's changes, bit for bit
        change = [0.0]
        total_edges = e if active is None else active.size
        for start in range(0, total_edges, chunk):
            if active is None:
                idx = slice(start, min(start + chunk, e))
                rows = np.arange(idx.start, idx.stop)
            else:
                rows = idx = active[start : start + chunk]
            change.append(_sweep_block(messages, belief, log_psi, a, b, e, rows, idx, sends,
                                       (changed, unfinite), product=product, damping=damping))
        change = float(np.max(np.array(change)))
        if change <= tolerance:
            break
        # the next sweep: nodes that heard a changed message, the edges they send on
        # (and, with damping, the changed edges themselves, and any non-finite message)
        dirty_mask = np.zeros(n, dtype=bool)
        dirty_mask[dst[changed]] = True
        again = dirty_mask[src]
        if damping:
            again |= changed
        again &= sends
        again |= unfinite
        dirty = np.flatnonzero(dirty_mask)
        active = np.flatnonzero(again[:e] | again[e:])
    for start in range(0, n, chunk):
        update_beliefs(slice(start, start + chunk))
    if return_messages:
        return belief, done, messages[:-1]
    return belief, done


class _PsiRows:
    """Rows of Ψ for blocks of edges: from a table, or from a function with a cache.

    A function (Ψ computed on demand) is asked once per edge and sweep at most; the
    rows of the edges still active are kept (up to :data:`_PSI_CACHE` bytes), since
    the active edges of later sweeps are mostly among them.
    """

    def __init__(self, log_psi, k):
        self.k = k
        self.function = log_psi if callable(log_psi) else None
        self.table = None if callable(log_psi) else np.asarray(log_psi, dtype=np.float64)
        self.ids = np.zeros(0, dtype=np.int64)
        self.rows = np.zeros((0, k, k))

    def keep(self, edges: np.ndarray) -> None:
        """Keep the rows of ``edges`` (sorted) for the coming sweep, if they fit."""
        if self.function is None:
            return
        if edges.size * self.k * self.k * 8 > _PSI_CACHE:
            self.ids, self.rows = np.zeros(0, dtype=np.int64), np.zeros((0, self.k, self.k))
            return
        rows = self(edges)
        self.ids, self.rows = edges, rows

    def __call__(self, edges: np.ndarray) -> np.ndarray:
        if self.table is not None:
            return self.table[edges]
        if self.ids.size == 0:
            return self.function(edges)
        pos = np.minimum(np.searchsorted(self.ids, edges), self.ids.size - 1)
        hit = self.ids[pos] == edges
        out = np.empty((edges.size, self.k, self.k))
        out[hit] = self.rows[pos[hit]]
        if not hit.all():
            out[~hit] = self.function(edges[~hit])
        return out


def _sweep_block(messages, belief, log_psi, a, b, e, rows, idx, sends, marks, *, product,
                 damping):
    """Both messages of the undirected edges ``rows`` (``idx``: the same, maybe a slice).

    Reads the old messages and the beliefs, writes the new messages in place and
    marks (``marks``: two boolean arrays over the messages) the rows that changed bit
    for bit and those holding a non-finite value; returns this block's largest change.
    """
    changed, unfinite = marks
    # leave out the receiver's own message
    h_fwd = belief[a[idx]] - messages[rows + e]
    h_bwd = belief[b[idx]] - messages[rows]
    psi_rows = log_psi(rows)
    out = []
    for h, message_rows, axis in ((h_fwd, rows, 1), (h_bwd, rows + e, 2)):
        new = np.empty(h.shape)
        _send(new, h, psi_rows, axis=axis, product=product)
        new[~sends[message_rows]] = 0.0
        old = messages[message_rows]
        if damping:
            new = new * (1.0 - damping) + damping * old
        out.append(np.abs(new - old))
        changed[message_rows] = np.any(new != old, axis=1)
        unfinite[message_rows] = ~np.isfinite(new).all(axis=1)
        out.append(new)
    # write after both directions have read the old values
    messages[rows] = out[1]
    messages[rows + e] = out[3]
    # np.max propagates NaN, as the literal max over all messages does
    return float(np.max(np.array([np.max(out[0], initial=0.0), np.max(out[2], initial=0.0)])))


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
