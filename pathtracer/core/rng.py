"""Counter-based random numbers: a stream per camera sample, independent of chunking.

Every camera sample (pixel, sample index) owns a 64-bit key; its k-th random
number is ``hash(key, k)``. A batch of paths that advances in lock-step shares
the counter ``k``, so splitting the image into chunks or processes never
changes which numbers a path sees: the same seed gives the same image.
The hash is the SplitMix64 finaliser, whose outputs on consecutive counters
pass BigCrush.
"""
from __future__ import annotations

import numpy as np

#: A seed is an unsigned 32-bit integer, as Mitsuba's sampler ``seed``.
SEED_MAX = 2 ** 32 - 1

_GOLDEN_INT, _M1_INT, _MASK = 0x9E3779B97F4A7C15, 0xBF58476D1CE4E5B9, (1 << 64) - 1
_GOLDEN = np.uint64(_GOLDEN_INT)
_M1 = np.uint64(_M1_INT)
_M2 = np.uint64(0x94D049BB133111EB)
_INV_2_53 = 1.0 / 9007199254740992.0


def mix64(x: np.ndarray) -> np.ndarray:
    """SplitMix64 finaliser on a uint64 array (wrapping arithmetic).

    In place on two work arrays: the same numbers as the textbook
    ``x = (x ^ (x >> 30)) * M1; ...`` with a third of its temporaries.
    """
    y = np.right_shift(x, np.uint64(30))
    y ^= x
    y *= _M1
    z = np.right_shift(y, np.uint64(27))
    y ^= z
    y *= _M2
    np.right_shift(y, np.uint64(31), out=z)
    y ^= z
    return y


def sample_keys(seed: int, sample_ids: np.ndarray) -> np.ndarray:
    """Keys of camera samples ``sample_ids`` (pixel * spp + sample) for ``seed``."""
    seed_key = mix64(np.array([seed & 0xFFFFFFFFFFFFFFFF], dtype=np.uint64) + _GOLDEN)
    return mix64(sample_ids.astype(np.uint64) * _GOLDEN ^ seed_key)


def _offset(k: int) -> np.uint64:
    """``k G`` wrapped to 64 bits, as uint64 arithmetic wraps (the hash input of counter k)."""
    return np.uint64((k * _GOLDEN_INT) & _MASK)


def _uniform(x: np.ndarray) -> np.ndarray:
    """Uniform numbers in [0, 1) from hash inputs ``x`` (uint64): the top 53 bits of
    ``mix64(x)``, exact in float64 (and so is the product)."""
    bits = mix64(x)
    bits >>= np.uint64(11)
    out = bits.astype(np.float64)
    out *= _INV_2_53
    return out


class RandomStream:
    """Uniform random numbers in [0, 1) for a batch of paths.

    Parameters
    ----------
    keys : (n,) uint64
        One key per path (see :func:`sample_keys`).
    counter : int
        Index of the next number in every path's sequence.
    lag : (n,) uint64, optional
        Per path, how far its own sequence is behind ``counter`` (a path that joined the
        batch later, :meth:`joined`): path i's next number is its number ``counter - lag[i]``.
        None: no path lags.
    """

    def __init__(self, keys: np.ndarray, counter: int = 0, lag: np.ndarray | None = None):
        self.keys = keys
        self.counter = counter
        self.lag = lag
        # hash(key + (k + 1) G) with k = counter - lag: the lag moves into the key once.
        self._base = keys if lag is None else keys - lag * _GOLDEN

    def __len__(self) -> int:
        return self.keys.shape[0]

    def next_1d(self) -> np.ndarray:
        """The next number of every path -> (n,) float64 in [0, 1)."""
        out = _uniform(self._base + _offset(self.counter + 1))
        self.counter += 1
        return out

    def next_2d(self) -> np.ndarray:
        """The next two numbers of every path -> (n, 2)."""
        out = self.numbers(self.counter, 2)
        self.counter += 2
        return out

    def numbers(self, counter: int, dims: int = 1, index: np.ndarray | None = None) -> np.ndarray:
        """Numbers ``counter`` to ``counter + dims - 1`` of the paths ``index`` (indices or a
        mask; default: all) -> (m,) for ``dims`` = 1, else (m, dims); the stream's own
        counter does not move.

        The same numbers as :meth:`subset` followed by :meth:`next_1d` at ``counter``
        (:meth:`next_2d` for two), without copying the streams: a path's k-th number is
        ``hash(key, k)`` alone.
        """
        if index is None:
            base = self._base
        else:
            index = np.asarray(index)
            base = np.take(self._base, np.flatnonzero(index) if index.dtype == bool else index)
        if dims == 1:
            return _uniform(base + _offset(counter + 1))
        offsets = np.array([_offset(counter + 1 + k) for k in range(dims)], dtype=np.uint64)
        return _uniform(base[:, None] + offsets)

    def subset(self, index: np.ndarray) -> "RandomStream":
        """The streams of paths ``index``, continuing at the same counter."""
        index = np.asarray(index)
        if index.dtype == bool:
            index = np.flatnonzero(index)
        lag = None if self.lag is None else np.take(self.lag, index)
        return RandomStream(np.take(self.keys, index), self.counter, lag)

    def branch(self, copies: int) -> "RandomStream":
        """``copies`` independent child streams per path (path-major order).

        Used by recursive ray tracing, where one hit spawns N indirect rays.
        Child j of path i is row ``i * copies + j``; it depends on the parent's key and
        own counter only. Children keep the counter (and lag), so they can be
        concatenated with streams that did not split.
        """
        parent = np.repeat(self.keys, copies)
        child = np.tile(np.arange(copies, dtype=np.uint64), len(self.keys))
        if self.lag is None:
            salt = np.uint64((self.counter * _M1_INT) & _MASK)
            lag = None
        else:
            lag = np.repeat(self.lag, copies)
            salt = (np.uint64(self.counter) - lag) * _M1
        return RandomStream(mix64(parent ^ mix64(child + salt + _M2)), self.counter, lag)

    def joined(self, other: "RandomStream") -> "RandomStream":
        """The paths of this stream, then those of ``other``, at this stream's counter.

        ``other``'s paths keep their own sequences: where ``other`` is behind (it started
        later), its paths lag by the difference. Pools that refill with new camera paths
        use it, so a path draws the same numbers whenever it started.
        """
        behind = self.counter - other.counter
        if behind < 0:
            raise ValueError(f"cannot join a stream ahead of this one ({other.counter} > "
                             f"{self.counter})")
        if self.lag is None and behind == 0 and other.lag is None:
            return RandomStream.concatenate([self, other])
        own = np.zeros(len(self), np.uint64) if self.lag is None else self.lag
        theirs = np.zeros(len(other), np.uint64) if other.lag is None else other.lag
        return RandomStream(np.concatenate((self.keys, other.keys)), self.counter,
                            np.concatenate((own, theirs + np.uint64(behind))))

    @staticmethod
    def concatenate(streams: list["RandomStream"]) -> "RandomStream":
        """One stream holding the paths of ``streams`` (all at the same counter)."""
        counters = {s.counter for s in streams}
        if len(counters) != 1:
            raise ValueError(f"cannot concatenate streams at different counters {counters}")
        if all(s.lag is None for s in streams):
            lag = None
        else:
            lag = np.concatenate([np.zeros(len(s), np.uint64) if s.lag is None else s.lag
                                  for s in streams])
        return RandomStream(np.concatenate([s.keys for s in streams]), counters.pop(), lag)
