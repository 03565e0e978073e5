r"""Loopy belief propagation in the log domain (§3.2.3, Eqs. 8–9; Fig. 6, step 5).

The messages of Eq. 9, on a synchronous schedule, normalised every sweep:

.. math:: M_{ij}(x_j) = Z \max_{x_i} \Psi(x_i, x_j)\, \Phi(x_i, y_i)
          \prod_{k \in N(i) \setminus j} M_{ki}(x_i)

(max-product; sum-product replaces the max by a sum), and the beliefs of Eq. 8,
``b_i(x_i) = Φ(x_i, y_i) Π_j M_ji(x_i)``, all as logarithms. The edge-constraint
rule enters as nodes that send no message (``silent``) and, in the paper's
reading, nodes that receive none either (``deaf``);
:func:`refsynth.synthesis.belief.fill.bp_fill` builds the model (the candidates, Φ and Ψ)
and calls :func:`belief_propagation`.

The cost: a sweep sends only the messages whose inputs changed bit for bit in
the last one (the others would come out the same bits), so after the first
sweep the work follows the few places still settling; Ψ may be a function that
computes the rows of a block of edges, so the (E, K, K) table need not be held
(a bounded cache keeps the rows most likely needed again). The max-product send
takes the sender's labels one at a time, on blocks of edges that stay in the
processor's cache. The result is that of plain synchronous sweeps over every
edge, bit for bit (``tests/test_bp_speed_memory.py`` and
``tests/test_bp_speed_sends.py`` compare them).

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

import inspect

import numpy as np

from refsynth.numeric import left_to_right_sum, portable_exp, portable_log

__all__ = ["belief_propagation"]

_CHUNK_FLOATS = 1 << 22  # about 32 MB of float64 per temporary block
_PSI_CACHE = 1 << 27  # bytes of Ψ rows kept between sweeps (128 MB)
_SEND_EDGES = 2048  # edges per block of a max-product send (128 KB of Ψ)


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
    progress=None,
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
        :func:`refsynth.synthesis.belief.fill.bp_fill` computes Ψ where it is needed);
        if it takes an ``out`` keyword, ``log_psi(edges, out=rows)`` writes them
        into ``rows``, an (m, K, K) view of the cache.
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
    progress : callable, optional
        ``progress(done, total)`` in sweeps of ``iterations``, after each chunk
        of edges sent (a sweep's part: the edges sent so far of its edges).
        The first sweep sends every edge and the later ones only those whose
        inputs changed, so the sweeps left cost less than the first.

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
    (on the Motorcycle at 450×375, x-stripes 78 % unknown: 236 000 of the
    255 000 pairs in the second sweep, 34 000 in the tenth, about 17 000 from
    the thirtieth). A message holding a non-finite value is
    always recomputed, so that the change is the literal ``max |new − old|``.
    The messages are updated in place, an undirected edge's two messages at
    a time (each reads only the other's old value), in chunks: the memory is
    the messages and the beliefs, with no copy of either. When Ψ is a
    function, its rows are kept in a cache of 128 MB (:data:`_PSI_CACHE`) that
    prefers the edges whose messages changed, so that each edge's Ψ is
    computed about once (once at 450×375, where the cache holds every edge;
    with 64 MB, 1.7 times, and BP on the colorization fill's observations
    takes 8 % more CPU there). When every edge's rows fit, the cache is the
    whole table, edge ``e`` in row ``e``, and a first sweep's block of edges
    has its rows written there in place (no copy).

    The max-product maximum is taken label by label with ``np.maximum``: the
    same numbers as ``np.max`` over the (E, k, k) array, since a maximum of the
    same floats does not depend on the order and no term ``log Ψ + h`` is −0
    (``h``, a belief less a message, never is: the beliefs start from ``+0``).

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
    log_psi = _PsiRows(log_psi, k, e)
    belief = np.empty((n, k))
    unfinite = np.zeros(2 * e, dtype=bool)  # messages holding a non-finite value
    chunk = max(1, _CHUNK_FLOATS // (k * k))

    def update_beliefs(nodes):
        """``unary + Σ incoming`` (left, up, right, down) of ``nodes`` (a slice or indices)."""
        rows = incoming[nodes]
        total = np.zeros((rows.shape[0], k))
        for column in range(incoming.shape[1]):  # left, up, right, down
            total += messages[rows[:, column]]
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
            if progress is not None:
                part = min(start + chunk, total_edges) / max(total_edges, 1)
                progress(done - 1 + part, iterations)
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

    A function (Ψ computed on demand) is asked for an edge's rows only when they are
    not in the cache, a buffer of :data:`_PSI_CACHE` bytes. After each block of sends
    (:meth:`store`) the cache keeps the new rows while it has room, and those of the
    edges whose messages changed even in place of the rows of edges not sent in this
    sweep (:meth:`keep`) or sent with no change: a changed message puts its edge in
    the next sweep, an unchanged one only maybe. Each row is the same function of its edge
    wherever it is computed: the numbers are those of one table.
    """

    def __init__(self, log_psi, k, n_edges):
        self.k = k
        self.function = log_psi if callable(log_psi) else None
        self.table = None if callable(log_psi) else np.asarray(log_psi, dtype=np.float64)
        self.whole = False
        if self.function is not None:
            capacity = max(0, min(_PSI_CACHE // (k * k * 8), n_edges))
            if capacity == n_edges and n_edges:
                # room for every edge: a table filled as edges are first asked for,
                # edge e in row e, the function writing straight into it when it can
                self.whole = True
                self.filled = np.zeros(n_edges, dtype=bool)
                self.buffer = np.empty((n_edges, k, k))
                self.into = _takes_out(self.function)
                return
            self.slot = np.full(n_edges, -1, dtype=np.int64)  # an edge's row in the buffer
            self.owner = np.full(capacity, -1, dtype=np.int64)  # a row's edge (−1: free)
            self.spare = np.zeros(capacity, dtype=bool)  # rows of edges settled this sweep
            self.buffer = np.empty((capacity, k, k))

    def keep(self, edges: np.ndarray) -> None:
        """This sweep sends ``edges``: the cached rows of the others may make room."""
        if self.function is None or self.whole or self.owner.size == 0:
            return
        wanted = np.zeros(self.slot.size, dtype=bool)
        wanted[edges] = True
        held = self.owner >= 0
        self.spare[:] = False
        self.spare[held] = ~wanted[self.owner[held]]

    def __call__(self, edges: np.ndarray) -> np.ndarray:
        if self.table is not None:
            return self.table[edges]
        if self.whole:
            return self._whole(edges)
        where = self.slot[edges]
        hit = where >= 0
        if hit.all():
            return self.buffer[where]
        if not hit.any():
            return self.function(edges)
        out = np.empty((edges.size, self.k, self.k))
        out[hit] = self.buffer[where[hit]]
        out[~hit] = self.function(edges[~hit])
        return out

    def _whole(self, edges: np.ndarray) -> np.ndarray:
        """The rows of ``edges`` from the whole table, computing those not yet in it."""
        # the sweeps ask for sorted, unique edges: first to last with no gap is a run
        run = edges.size and edges[-1] - edges[0] == edges.size - 1
        if run:
            block = slice(int(edges[0]), int(edges[-1]) + 1)
            if not self.filled[block].any():  # a first sweep's block: written in place
                if self.into:
                    self.function(edges, out=self.buffer[block])
                else:
                    self.buffer[block] = self.function(edges)
                self.filled[block] = True
                return self.buffer[block]
        missing = edges[~self.filled[edges]]
        if missing.size:
            self.buffer[missing] = self.function(missing)
            self.filled[missing] = True
        return self.buffer[block] if run else self.buffer[edges]

    def store(self, edges: np.ndarray, rows: np.ndarray, moved: np.ndarray) -> None:
        """After a block of sends: keep what fits of ``rows``, the ``moved`` edges first."""
        if self.function is None or self.whole or self.owner.size == 0:
            return
        where = self.slot[edges]
        settled = (where >= 0) & ~moved
        self.spare[where[settled]] = True
        new = where < 0
        for first in (True, False):
            pick = np.flatnonzero(new & (moved if first else ~moved))
            if pick.size == 0:
                continue
            free = np.flatnonzero(self.owner < 0)
            if first and free.size < pick.size:  # the settled edges' rows make room
                spare = np.flatnonzero(self.spare)[: pick.size - free.size]
                self.slot[self.owner[spare]] = -1
                self.owner[spare] = -1
                self.spare[spare] = False
                free = np.concatenate([free, spare])
            pick, free = pick[: free.size], free[: pick.size]
            self.owner[free] = edges[pick]
            self.slot[edges[pick]] = free
            if free.size and free[-1] - free[0] == free.size - 1:  # a run of free rows
                free = slice(int(free[0]), int(free[-1]) + 1)
            self.buffer[free] = rows if pick.size == edges.size else rows[pick]


def _takes_out(function) -> bool:
    """Whether ``function`` takes an ``out`` keyword (False when its signature is unknown)."""
    try:
        return "out" in inspect.signature(function).parameters
    except (TypeError, ValueError):  # e.g. a builtin without a signature
        return False


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
        sent = sends[message_rows]
        if not sent.all():
            new[~sent] = 0.0
        old = messages[message_rows]
        if damping:
            new = new * (1.0 - damping) + damping * old
        out.append(np.abs(new - old))
        changed[message_rows] = _row_any(new != old)
        unfinite[message_rows] = _row_any(~np.isfinite(new))
        out.append(new)
    # write after both directions have read the old values
    messages[rows] = out[1]
    messages[rows + e] = out[3]
    log_psi.store(np.asarray(rows), psi_rows, changed[rows] | changed[rows + e])
    # np.max propagates NaN, as the literal max over all messages does
    return float(np.max(np.array([np.max(out[0], initial=0.0), np.max(out[2], initial=0.0)])))


def _send(out: np.ndarray, h: np.ndarray, log_psi: np.ndarray, *, axis: int, product: str):
    """One direction of Eq. 9 for a block of edges, normalised (max or log-sum = 0).

    ``axis`` is the axis of ``log_psi`` that holds the sender's labels: 1 when the
    sender is the edge's first node, 2 when it is the second.
    """
    if product == "max":
        _max_product(out, h, log_psi, axis)
        return
    k = h.shape[1]
    chunk = max(1, _CHUNK_FLOATS // (k * k))
    for start in range(0, h.shape[0], chunk):
        sl = slice(start, start + chunk)
        t = log_psi[sl] + (h[sl, :, None] if axis == 1 else h[sl, None, :])
        top = t.max(axis=axis)
        terms = portable_exp(t - np.expand_dims(top, axis))
        m = portable_log(left_to_right_sum(terms, axis=axis)) + top
        out[sl] = m - _logsumexp(m)[:, None]


def _max_product(out: np.ndarray, h: np.ndarray, log_psi: np.ndarray, axis: int):
    """Max-product Eq. 9: ``max over the sender's labels l of log Ψ + h[l]``, less its max.

    The sender's labels are taken one at a time, each term ``log Ψ + h[l]`` the same
    IEEE sum as in the whole (E, k, k) array, and the running maximum kept in
    ``out``, in blocks of :data:`_SEND_EDGES` edges that stay in the cache. A maximum
    of the same numbers is the same number whatever the order it is taken in
    (no term is ever −0: a belief less a message never is, see
    :func:`belief_propagation`), NaN propagating as in ``np.max``.
    """
    k = h.shape[1]
    term = np.empty((min(_SEND_EDGES, h.shape[0]), k))
    for start in range(0, h.shape[0], _SEND_EDGES):
        sl = slice(start, start + _SEND_EDGES)
        psi_block, h_block, m = log_psi[sl], h[sl], out[sl]
        t = term[: m.shape[0]]
        for label in range(k):
            # the sender's label indexes rows of Ψ (axis 1) or its columns (axis 2)
            rows = psi_block[:, label, :] if axis == 1 else psi_block[:, :, label]
            np.add(rows, h_block[:, label : label + 1], out=m if label == 0 else t)
            if label:
                np.maximum(m, t, out=m)
        m -= _row_max(m)


def _row_max(x: np.ndarray) -> np.ndarray:
    """``x.max(axis=1, keepdims=True)``, column by column (a max is exact in any order).

    Used on messages, which hold no −0 (see :func:`_max_product`), and NaN
    propagates as in ``np.max``; a short row's reduction is slow in NumPy.
    """
    top = x[:, 0].copy()
    for column in range(1, x.shape[1]):
        np.maximum(top, x[:, column], out=top)
    return top[:, None]


def _row_any(x: np.ndarray) -> np.ndarray:
    """``np.any(x, axis=1)`` for a boolean (m, k) array, column by column."""
    out = x[:, 0].copy()
    for column in range(1, x.shape[1]):
        np.logical_or(out, x[:, column], out=out)
    return out


def _logsumexp(x: np.ndarray) -> np.ndarray:
    """``log Σ exp`` over the labels (axis 1), portable and left to right."""
    top = x.max(axis=1)
    return portable_log(left_to_right_sum(portable_exp(x - top[:, None]), axis=1)) + top
