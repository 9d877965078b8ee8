"""The repeated integration of many intervals of one recording (:class:`IntervalIntegrator`)."""

from __future__ import annotations

import sys
import weakref
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .products import (
    bit_reversal,
    prefix_product_soa,
    prefix_products_halves,
    rk4_constants,
    rk4_soa,
    tree_product_soa,
    tree_products_halves,
    weighted_rotations_soa,
)
from .quaternions import IDENTITY, quat_normalize

#: steps of one block of a long interval: an interval of more steps is integrated block by block
BLOCK = 1 << 12
#: steps whose integration temporaries exist at once (gathered blocks of long intervals)
CHUNK = 1 << 18
#: steps whose RK4 stages are formed at once: their temporaries stay in the processor's cache (2.4 times as fast
#: as 2^18 at a time)
RK4_CHUNK = 1 << 13

#: the most bytes of gathered RK4 factors whose tree levels :meth:`IntervalIntegrator.from_samples` keeps for
#: :meth:`IntervalIntegrator.sensitivity` (twice this held between them)
LEVEL_BYTES = 1 << 22

#: padded steps of short intervals (up to BLOCK steps) integrated together: a recording of more is integrated a
#: part of consecutive intervals at a time, so that memory does not follow how many short rotations it holds
PART_STEPS = CHUNK

#: samples whose per-sample Jacobians :meth:`IntervalIntegrator.weighted_sum` asks for at once (several short
#: intervals' together)
SPAN = 1 << 12

#: the most steps whose RK4 step-length factors an integrator keeps (five numbers a step: memory that would
#: otherwise follow the length of the recording)
RK4_CONSTANT_STEPS = 1 << 16

#: samples of an interval whose weighted sum (:meth:`IntervalIntegrator.weighted_sum`) is one product; a longer
#: interval's is summed block by block
SUM_BLOCK = 1 << 17


class IntervalIntegrator:
    """Repeated integration of many intervals of one recording (for solvers).

    The sample layout is fixed once; :meth:`__call__` then takes rates for
    every sample of the recording (or :meth:`from_samples` only for the
    samples listed in :attr:`samples`) and returns each interval's attitude
    change. This is the inner loop of the gyroscope cost functions (Zhang
    2021, eq. 14; Tedaldi 2014), so it avoids all per-call bookkeeping.

    The temporaries follow neither the length of one interval nor how many
    there are: intervals of up to :data:`BLOCK` steps are grouped by their
    length rounded up to a power of two, each group padded to its own length,
    in parts of consecutive intervals of up to :data:`PART_STEPS` padded steps
    integrated one part at a time (one part, as a rule: a recording of hours of
    short turns has several); a longer interval is cut into blocks of
    :data:`BLOCK` steps, whose products are then multiplied together, and the
    blocks are processed :data:`CHUNK` steps at a time. The blocks are
    aligned on the pairwise (tree) products of the module docstring, and their
    prefix products continue from the blocks before them in the order the
    whole interval's would be formed, so the results are the same to the last
    bit as integrating each interval at once (and, every product being formed
    per interval, in one part or in many).

    Parameters
    ----------
    t : (N,) array_like
        Sample times [s] of the whole recording.
    starts, stops : (M,) array_like of int
        Each interval integrates from sample ``starts[i]`` to sample
        ``stops[i]`` inclusive.
    """

    def __init__(self, t: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> None:
        t = np.asarray(t, dtype=np.float64)
        starts = np.asarray(starts, dtype=np.intp)
        stops = np.asarray(stops, dtype=np.intp)
        if starts.shape != stops.shape or starts.size == 0 or np.any(stops <= starts):
            raise ValueError("each interval needs stops[i] > starts[i]")
        if np.any(starts < 0) or np.any(stops >= t.shape[0]):
            raise ValueError("interval indices lie outside the recording")
        nsteps = stops - starts
        self._lay_out_steps(t, starts, stops)
        # intervals grouped by their length rounded up to a power of two: each group is padded to its own
        # length (with identity steps), not to the longest interval's, so memory follows the samples integrated
        widths = 1 << np.ceil(np.log2(np.maximum(nsteps, 1))).astype(int)
        self._lay_out_short(widths, nsteps)
        self._lay_out_long(widths, nsteps)

    def _lay_out_steps(self, t: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> None:
        """The steps of every interval, the samples they read and the RK4 factors' pairs of samples."""
        nsteps = stops - starts
        # the steps (sample k → k+1) of every interval, sorted and without repeats
        step = np.zeros(t.shape[0], np.int32)
        np.add.at(step, starts, 1)
        np.add.at(step, stops, -1)
        steps = np.flatnonzero(np.cumsum(step, dtype=np.int32) > 0)
        del step
        used = np.zeros(t.shape[0], bool)  # the samples the steps read: steps and steps + 1, in one pass
        used[steps] = True
        used[steps + 1] = True
        self.samples = np.flatnonzero(used)
        #: positions in ``samples`` of each step's first sample
        #: (the second sample of a step follows its first there: ``_i0 + 1``)
        self._i0 = np.cumsum(used, dtype=np.int32 if used.size < 2**31 else np.intp)[steps]
        self._i0 -= 1
        del used
        dt = t[steps + 1] - t[steps]  # each step's length
        self.starts, self.stops = starts, stops
        self._nsteps = nsteps
        #: position in ``samples`` of each interval's first sample (its samples follow it there)
        self._first = np.searchsorted(self.samples, starts)
        #: position in ``steps`` of each interval's first step (its steps follow it there)
        self._step0 = np.searchsorted(steps, starts)
        #: the RK4 factors are formed for every pair of consecutive samples of ``samples`` (contiguous rates, no
        #: gather; a pair that is no step, from one interval's end to the next one's start, is never read):
        #: their step lengths (0 for those), and the place of each step among them
        self._npairs = self.samples.size - 1
        self._pair_dt = np.zeros(self._npairs)
        self._pair_dt[self._i0] = dt
        del dt
        #: the RK4 factors of the step lengths (:func:`rk4_constants`), formed once when they are few
        self._rk4_constants = rk4_constants(self._pair_dt) if self._npairs <= RK4_CONSTANT_STEPS else None

    def _lay_out_short(self, widths: np.ndarray, nsteps: np.ndarray) -> None:
        """The intervals of up to :data:`BLOCK` steps in parts (:class:`_ShortPart`), and the buffers kept for
        them."""
        starts = self.starts
        #: the short intervals in parts of consecutive intervals of up to PART_STEPS padded steps (one part, as
        #: a rule): each part's groups, the layout of its attitudes (_ShortPart)
        self._parts = []
        #: per interval: its part (−1 for a long one), and the position of its first attitude in its part's
        self._part_of = np.full(len(starts), -1)
        self._att_first = np.full(len(starts), -1)
        short = np.nonzero(widths <= BLOCK)[0]
        ends = np.cumsum(widths[short])
        a = 0
        while a < short.size:  # each part as many intervals as fit in PART_STEPS (at least one)
            b = max(a + 1, int(np.searchsorted(ends, (ends[a - 1] if a else 0) + PART_STEPS, side="right")))
            self._part_of[short[a:b]] = len(self._parts)
            self._parts.append(self._short_part(short[a:b], widths, nsteps))
            a = b
        #: bytes of the groups' gathered factors (and again of their tree levels), when they form one part
        self._group_bytes = 32 * self._parts[0].columns if len(self._parts) == 1 else None
        #: (the factors, weakly; their gathered columns; their tree levels) of the last from_samples()
        self._tree_levels: tuple | None = None
        #: the rotations array of the last sensitivity() (reused once nothing else refers to it)
        self._rotations: np.ndarray | None = None
        #: sensitivity()'s attitude temporaries (every group's, then every sample's), kept when small
        self._attitude_buffers = None
        if len(self._parts) == 1:
            part = self._parts[0]
            if 32 * (part.columns + 1 + part.att_index.size) <= LEVEL_BYTES:
                self._attitude_buffers = (np.empty((4, part.columns + 1)), np.empty((4, part.att_index.size)))

    def _lay_out_long(self, widths: np.ndarray, nsteps: np.ndarray) -> None:
        """The intervals of more than :data:`BLOCK` steps: their blocks, grouped by how many they have."""
        # longer intervals: blocks of BLOCK steps, then per interval the product of its blocks (their number
        # rounded up to a power of two, grouped by it)
        self._long = np.nonzero(widths > BLOCK)[0]
        nblocks = -(-nsteps[self._long] // BLOCK)
        self._block_first = np.concatenate([[0], np.cumsum(nblocks)])  # each long interval's first block
        owner = np.repeat(np.arange(self._long.size), nblocks)
        #: per block: position in ``steps`` of its first step, and how many of its steps are the interval's
        self._block_step0 = (self._step0[self._long][owner]
                             + BLOCK * (np.arange(owner.size) - self._block_first[owner]))
        self._block_len = np.minimum(BLOCK, self._step0[self._long][owner] + nsteps[self._long][owner]
                                     - self._block_step0)
        self._long_groups = []
        for count in np.unique(widths[self._long] // BLOCK):
            which = np.nonzero(widths[self._long] // BLOCK == count)[0]  # positions in _long
            pos = np.arange(count)[None, :]
            valid = pos < nblocks[which, None]
            self._long_groups.append((which, np.where(valid, self._block_first[which, None] + pos, owner.size)))

    def _short_part(self, members: np.ndarray, widths: np.ndarray, nsteps: np.ndarray) -> _ShortPart:
        """The groups of the short intervals ``members`` (by width, widest first) and their attitudes' layout."""
        groups, att_index, att_trapezoid = [], [], []
        column = place = 0
        for width in np.unique(widths[members])[::-1]:  # widest first
            group = members[widths[members] == width]
            gather, trapezoid = self._layout(self._step0[group], nsteps[group], int(width))
            order = bit_reversal(int(width))
            # each group's steps are gathered step-major (W, members) in bit-reversed order (tree_products_halves)
            groups.append((group, np.ascontiguousarray(gather[:, order].T)))
            # row j's samples: the start (the identity, marked −1), then the attitude after step i at place
            # order[i] of row j; each row as long as its interval's samples
            m, n = len(group), nsteps[group]
            index = np.empty((m, int(width) + 1), dtype=np.intp)
            index[:, 0] = -1
            index[:, 1:] = column + order[None, :] * m + np.arange(m)[:, None]
            real = np.arange(int(width) + 1)[None, :] <= n[:, None]
            att_index.append(index[real])
            att_trapezoid.append(trapezoid[real])
            self._att_first[group] = place + np.concatenate([[0], np.cumsum(n + 1)[:-1]])
            place += int(np.sum(n + 1))
            column += int(width) * len(group)
        att_index = np.concatenate(att_index)
        att_index[att_index < 0] = column  # the start of each interval: the identity
        return _ShortPart(groups, att_index, np.concatenate(att_trapezoid), column)

    def _part_rotations(self, k: int, s: np.ndarray) -> np.ndarray:
        """The ``A_j`` of every sample of part ``k``'s intervals from the RK4 factors ``s`` (:meth:`step_factors`),
        as :meth:`sensitivity` forms them (the same numbers)."""
        part = self._parts[k]
        return self._rotations_of(part, prefix_products_halves([s.take(tree, axis=1) for _, tree in part.groups]))

    @staticmethod
    def _rotations_of(part: _ShortPart, prefixes: list[np.ndarray], buffers: tuple | None = None,
                      out: np.ndarray | None = None) -> np.ndarray:
        """The ``A_j`` ((samples, 3, 3) view of a (3, samples, 3) array, :func:`weighted_rotations_soa`) of the
        samples of ``part`` from its groups' prefix products: every attitude, then each sample's (into
        ``buffers`` and ``out`` when given). Empties ``prefixes`` once they are copied (freed before the
        rotations are formed)."""
        att = np.concatenate([pre.reshape(4, -1) for pre in prefixes] + [IDENTITY[:, None]], axis=1,
                             out=None if buffers is None else buffers[0])
        prefixes.clear()
        att = att.take(part.att_index, axis=1, out=None if buffers is None else buffers[1])
        return weighted_rotations_soa(att, part.att_trapezoid, out)

    def _layout(self, step0: np.ndarray, nsteps: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
        """Columns of each interval's steps among the RK4 factors (the identity column past its end), and the
        trapezoid weights of its samples (positions 0..width), for intervals starting at ``step0`` in ``steps``."""
        pos = np.arange(width)[None, :]
        valid = pos < nsteps[:, None]
        step = np.where(valid, step0[:, None] + pos, 0)
        gather = np.where(valid, self._i0[step], self._npairs)
        dtp = np.zeros((len(step0), width + 2))
        dtp[:, 1:-1] = np.where(valid, self._pair_dt[self._i0[step]], 0.0)
        return gather, 0.5 * (dtp[:, :-1] + dtp[:, 1:])

    def __call__(self, rates: np.ndarray) -> np.ndarray:
        """Attitude change (M, 4) of every interval for rates (N, 3) [rad/s]."""
        return self.from_samples(np.asarray(rates, dtype=np.float64)[self.samples])

    def step_factors(self, rates: np.ndarray) -> np.ndarray:
        """RK4 factors (4, len(samples)) of every pair of consecutive :attr:`samples` (the steps among them), then
        an identity column for the padding.

        For :meth:`from_samples` and :meth:`sensitivity` (``steps``) when both integrate the same rates.
        """
        rates = np.asarray(rates, dtype=np.float64)
        n = self._npairs
        s = np.empty((4, n + 1))
        for a in range(0, n, RK4_CHUNK):  # the stages' temporaries RK4_CHUNK steps at a time
            b = min(n, a + RK4_CHUNK)
            chunk = rates[a : b + 1].T.copy()  # the rates component-first, a chunk at a time
            constants = None if self._rk4_constants is None else [c[a:b] for c in self._rk4_constants]
            s[:, a:b] = rk4_soa(chunk[:, :-1], chunk[:, 1:], self._pair_dt[a:b], constants)  # eqs. (Q2), (Q3)
        s[:, n] = IDENTITY
        return s

    def _steps_at(self, rates: np.ndarray, gather: np.ndarray) -> np.ndarray:
        """RK4 factors (4, *gather.shape) of the columns ``gather`` of :meth:`step_factors` (identity past the
        last), as it forms them."""
        flat = gather.ravel()
        real = flat < self._npairs
        out = np.empty((4, flat.size))
        out[:, ~real] = IDENTITY[:, None]
        idx = flat[real]
        rates = np.asarray(rates, dtype=np.float64)
        w0, w1 = rates.take(idx, axis=0).T.copy(), rates.take(idx + 1, axis=0).T.copy()
        out[:, real] = rk4_soa(w0, w1, self._pair_dt[idx])  # eqs. (Q2), (Q3)
        return out.reshape((4, *gather.shape))

    def _block_chunks(self):
        """Ranges of long-interval blocks processed together (:data:`CHUNK` steps) and their factor columns."""
        rows = max(1, CHUNK // BLOCK)
        for a in range(0, self._block_step0.size, rows):
            b = min(self._block_step0.size, a + rows)
            gather, _ = self._layout(self._block_step0[a:b], self._block_len[a:b], BLOCK)
            yield a, b, gather

    def _block_prefix(self, products: np.ndarray) -> list[np.ndarray]:
        """Per long interval, the prefix products (4, blocks) of its blocks' products (4, all blocks)."""
        padded = np.concatenate([products, IDENTITY[:, None]], axis=1)
        out: list[np.ndarray] = [np.empty(0)] * self._long.size
        for which, gather in self._long_groups:
            pre = prefix_product_soa(padded.take(gather, axis=1))
            for i, k in enumerate(which):
                out[k] = pre[:, i]
        return out

    def from_samples(self, rates: np.ndarray, steps: np.ndarray | None = None) -> np.ndarray:
        """Attitude change (M, 4) from rates (len(samples), 3) at :attr:`samples` only.

        ``steps``: their RK4 factors when already formed (:meth:`step_factors` of these rates).
        """
        s = self.step_factors(rates) if steps is None else steps
        q = np.empty((len(self.starts), 4))
        self._tree_levels = None
        for part in self._parts:  # one part at a time: its temporaries are all that exist at once
            order = np.concatenate([members for members, _ in part.groups])
            fs = [s.take(tree, axis=1) for _, tree in part.groups]
            # the caller keeps these factors: their gathered columns and tree levels kept for sensitivity()'s
            # prefix products of the same factors, when small (and one part)
            keep = steps is not None and self._group_bytes is not None and self._group_bytes <= LEVEL_BYTES
            levels = [] if keep else None
            q[order] = tree_products_halves(fs, levels).T
            if levels is not None:
                self._tree_levels = (weakref.ref(steps), fs, levels)
            del fs
        if self._long.size:
            products = np.empty((4, self._block_step0.size))
            for a, b, gather in self._block_chunks():
                products[:, a:b] = tree_product_soa(s.take(gather, axis=1))
            products = np.concatenate([products, IDENTITY[:, None]], axis=1)
            for which, gather in self._long_groups:
                q[self._long[which]] = tree_product_soa(products.take(gather, axis=1)).T
        return quat_normalize(q)

    def sensitivity(self, rates: np.ndarray, steps: np.ndarray | None = None
                    ) -> tuple[np.ndarray, _SensitivityWeights]:
        """End attitudes and the weights of the first-order attitude sensitivity.

        A perturbation ``δω`` of the rates turns the end attitude by
        ``δφ = R_endᵀ · Σ_j A_j δω_j`` (end frame), the trapezoidal rule on
        ``∫ R(t) δω(t) dt`` with ``R(t)`` the attitude relative to the
        interval's start. Used for analytic Jacobians of eq. (14) of Zhang 2021.

        Parameters
        ----------
        rates : (len(samples), 3) ndarray
            Rates [rad/s] at :attr:`samples`.
        steps : ndarray, optional
            Their RK4 factors when already formed (:meth:`step_factors`).

        Returns
        -------
        q_end : (M, 4) ndarray
            Attitude change of each interval (as :meth:`from_samples`).
        weights : sequence of M (n_m + 1, 3, 3) ndarrays
            ``A_j`` for the ``n_m + 1`` samples of interval ``m``, in the
            order they have in :attr:`samples` from :attr:`first_sample`
            (those of a long interval are formed when asked for, from the
            RK4 factors and the products of its blocks: :meth:`weighted_sum`
            takes them block by block, and no attitude of every sample exists).
        """
        s = self.step_factors(rates) if steps is None else steps
        q_end = np.empty((len(self.starts), 4))
        weights = _SensitivityWeights(self)
        for part in self._parts:  # pre: the attitude after each step, bit-reversed (W, members) per group
            kept = self._tree_levels
            if steps is not None and kept is not None and kept[0]() is steps:  # from_samples() of these factors
                prefixes = prefix_products_halves(kept[1], iter(kept[2]))
            else:
                prefixes = prefix_products_halves([s.take(tree, axis=1) for _, tree in part.groups])
            for (members, _), pre in zip(part.groups, prefixes, strict=True):
                q_end[members] = pre[:, -1].T  # the last place holds the last step in bit-reversed order too
            del pre
            if len(self._parts) == 1:  # its A_j now (temporaries kept by the integrator when small: reused)
                rot = self._rotations_of(part, prefixes, self._attitude_buffers, self._rotations_buffer())
                for members, _ in part.groups:
                    for k in members:
                        weights.items[k] = rot[self._att_first[k] : self._att_first[k] + self._nsteps[k] + 1]
            del prefixes
        if len(self._parts) > 1:  # many short intervals: each part's A_j formed when weighted_sum() reaches it
            weights.factors = s
        if self._long.size:
            products = np.empty((4, self._block_step0.size))
            for a, b, gather in self._block_chunks():
                products[:, a:b] = tree_product_soa(s.take(gather, axis=1))
            prefix = self._block_prefix(products)
            # a long interval's attitudes are formed again when asked for: from the factors when the caller keeps
            # them anyway, else from the rates
            weights.rates, weights.steps = rates, steps
            for i, k in enumerate(self._long):
                q_end[k] = prefix[i][:, -1]  # the product of all its blocks, as from_samples forms it
                weights.prefix[k] = (i, prefix[i])
        return quat_normalize(q_end), weights

    def _rotations_buffer(self) -> np.ndarray:
        """The (3, samples, 3) array the short intervals' ``A_j`` are written into: the one of the last
        :meth:`sensitivity` again once nothing refers to it any more (its weights and every view of them gone:
        a fit's Jacobians are formed one after the other), else a new one."""
        buf = self._rotations
        self._rotations = None
        if buf is None or sys.getrefcount(buf) > 2:  # 2: the name here and getrefcount's argument
            buf = np.empty((3, self._parts[0].att_index.size, 3))
        self._rotations = buf
        return buf

    def _trapezoid(self, k: int) -> np.ndarray:
        """Trapezoid weights (n + 1,) of the samples of interval ``k``."""
        dt = self._pair_dt[self._first[k] : self._first[k] + self._nsteps[k]]  # its steps: consecutive pairs
        return 0.5 * (np.concatenate([[0.0], dt]) + np.concatenate([dt, [0.0]]))

    @property
    def first_sample(self) -> np.ndarray:
        """(M,) position in :attr:`samples` of each interval's first sample; its others follow it there."""
        return self._first

    def _span_end(self, m: int) -> int:
        """The end of the samples of interval ``m`` and the short intervals after it, up to :data:`SPAN` samples
        from its first (one call of :meth:`weighted_sum`'s ``values``)."""
        p0 = int(self._first[m])
        end = p0 + int(self._nsteps[m]) + 1
        k = m + 1
        while k < len(self._first) and self._first[k] >= p0:
            stop = int(self._first[k] + self._nsteps[k]) + 1
            if self._nsteps[k] + 1 > SUM_BLOCK or stop - p0 > SPAN:
                break
            end = max(end, stop)
            k += 1
        return end

    def weighted_sum(self, weights: _SensitivityWeights,
                     values: np.ndarray | Callable[[int, int], np.ndarray]) -> np.ndarray:
        """``Σ_j A_j v_j`` over each interval's samples: (M, 3, P) from the weights of :meth:`sensitivity`.

        ``values`` (len(samples), 3, P) are per-sample Jacobians (e.g. ``∂ω/∂θ``),
        or a function giving those of the samples at positions ``a … b − 1`` of
        :attr:`samples` (``values(a, b)``, (b − a, 3, P); the array it returns is
        read before the next call, so it may reuse one buffer): then only one
        interval's (or block's) Jacobian exists at a time, whatever the length
        of the recording.
        Each interval's samples are consecutive in :attr:`samples`, so this is
        one (3 × 3n)·(3n × P) product per interval over its own samples, with
        no gathered copy and no work on padding; an interval of more than
        :data:`SUM_BLOCK` samples is summed block by block (its ``A_j`` formed a
        block at a time). Both forms of ``values`` give the same products.
        """
        get = values if callable(values) else (lambda a, b: values[a:b])
        out = None
        span = (0, 0, None)  # samples [a, b) of the values last asked for, and those values
        for m, (p0, n) in enumerate(zip(self._first, self._nsteps + 1, strict=True)):
            if n <= SUM_BLOCK:
                a = weights[m][:n].transpose(1, 0, 2).reshape(3, 3 * n)  # [A_0 A_1 …]
                if not (span[0] <= p0 and p0 + n <= span[1]):  # the values of this and the next short intervals
                    span = (p0, self._span_end(m), None)
                    span = (*span[:2], get(*span[:2]))
                v = span[2][p0 - span[0] : p0 - span[0] + n]
                if out is None:
                    out = np.empty((len(self.starts), 3, v.shape[2]))
                out[m] = a @ v.reshape(3 * n, -1)
                continue
            span = (0, 0, None)  # the values are asked for again: the buffer they lie in is reused
            for j in range(0, n, SUM_BLOCK):
                k = min(n, j + SUM_BLOCK)
                a = weights.block(m, j, k).transpose(1, 0, 2).reshape(3, 3 * (k - j))
                v = get(p0 + j, p0 + k)
                if out is None:
                    out = np.empty((len(self.starts), 3, v.shape[2]))
                if j == 0:
                    out[m] = 0.0
                out[m] += a @ v.reshape(3 * (k - j), -1)
        return out


class _ShortPart(NamedTuple):
    """Consecutive short intervals integrated together (:attr:`IntervalIntegrator._parts`)."""

    #: (members, gathered factor columns (W, members) in bit-reversed order) per width, widest first
    groups: list[tuple[np.ndarray, np.ndarray]]
    #: per attitude of the part's samples: its column among the groups' prefix products (the identity last)
    att_index: np.ndarray
    #: and its trapezoid weight
    att_trapezoid: np.ndarray
    #: the groups' padded steps
    columns: int


class _SensitivityWeights:
    """The ``A_j`` of :meth:`IntervalIntegrator.sensitivity`, one (n + 1, 3, 3) array per interval.

    Those of the short intervals are kept as arrays; those of a long interval
    are formed from its attitudes (4, n + 1) when asked for, whole or a block
    of samples at a time (:meth:`block`), so that no (n + 1, 3, 3) array of a
    long interval has to exist.
    """

    def __init__(self, integrator: IntervalIntegrator) -> None:
        self.integrator = integrator
        self.items: list[np.ndarray | None] = [None] * len(integrator.starts)
        #: per long interval: its place in ``integrator._long`` and the prefix products (4, blocks) of its blocks
        self.prefix: dict[int, tuple[int, np.ndarray]] = {}
        self.rates: np.ndarray | None = None  # the rates (len(samples), 3) the attitudes were integrated from
        self.steps: np.ndarray | None = None  # their RK4 factors, when the caller passed them
        #: the RK4 factors of every step, when the short intervals are in several parts (their A_j formed a part
        #: at a time, from these), and the part last formed: (its number, its A_j)
        self.factors: np.ndarray | None = None
        self._part: tuple[int, np.ndarray | None] = (-1, None)

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, m: int) -> np.ndarray:
        item = self.items[m]
        return item if item is not None else self.block(m, 0, self.integrator._nsteps[m] + 1)

    def _short(self, m: int) -> np.ndarray | None:
        """``A_j`` of short interval ``m`` of an integrator whose short intervals are in several parts (its
        part's formed when first asked for, the one before dropped first), else None."""
        integ = self.integrator
        k = int(integ._part_of[m]) if self.factors is not None else -1
        if k < 0:
            return None
        if self._part[0] != k:
            self._part = (-1, None)  # one part's A_j at a time
            self._part = (k, integ._part_rotations(k, self.factors))
        first = integ._att_first[m]
        return self._part[1][first : first + integ._nsteps[m] + 1]

    def attitudes(self, m: int, start: int, stop: int) -> np.ndarray:
        """Attitudes (4, stop − start) of samples ``start … stop − 1`` of long interval ``m`` (relative to its start).

        The RK4 factors of the blocks holding them and their prefix products,
        each continuing from the product of the blocks before it (``carry``),
        formed exactly as :meth:`IntervalIntegrator.sensitivity` formed every
        block's: the same numbers as the attitudes of the whole interval,
        without keeping the factors or attitudes of every step.
        """
        integ = self.integrator
        i, prefix = self.prefix[m]
        first = int(integ._block_first[i])
        c0 = max(start - 1, 0) // BLOCK  # sample p ≥ 1 is the attitude after step p − 1
        c1 = max(stop - 2, 0) // BLOCK + 1
        blocks = np.arange(first + c0, first + c1)
        gather, _ = integ._layout(integ._block_step0[blocks], integ._block_len[blocks], BLOCK)
        carry = np.empty((4, c1 - c0))
        for c in range(c0, c1):
            carry[:, c - c0] = IDENTITY if c == 0 else prefix[:, c - 1]
        factors = integ._steps_at(self.rates, gather) if self.steps is None else self.steps.take(gather, axis=1)
        local = prefix_product_soa(factors, carry)
        local[:, :, -1] = prefix[:, c0:c1]  # the last of a block continues the blocks' own prefix
        out = np.empty((4, stop - start))
        lo = start
        if start == 0:
            out[:, 0] = IDENTITY
            lo = 1
        if stop > lo:
            flat = local.reshape(4, -1)
            out[:, lo - start :] = flat[:, lo - 1 - c0 * BLOCK : stop - 1 - c0 * BLOCK]
        return out

    def block(self, m: int, start: int, stop: int) -> np.ndarray:
        """``A_j`` (stop − start, 3, 3) of samples ``start … stop − 1`` of interval ``m``."""
        item = self.items[m]
        if item is None:
            item = self._short(m)
        if item is not None:
            return item[start:stop]
        return weighted_rotations_soa(self.attitudes(m, start, stop), self.integrator._trapezoid(m)[start:stop])
