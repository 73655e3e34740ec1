"""Reading the same sensors at every control step, cheaply: :class:`Sampler`.

A hook that samples the same sensors at every control step (the step odometer, a logger) needs neither
``read``'s checks nor its dict at each step, and often not the values at once either: it needs them
all when it next uses them (the odometer, once per brain period). :meth:`ArticulatedBackend.sampler
<neuronav.engine.articulated.ArticulatedBackend.sampler>` checks the names once and gives a
:class:`Sampler`: called, it returns one sample; :meth:`Sampler.record` keeps the current sample in a
buffer and :meth:`Sampler.drain` gives the kept samples as one array. An engine may record its raw
state there and finish it for all rows at once in :meth:`~Sampler.drain` (MuJoCo: the joint angles and
the legs' contact forces, their norms taken at the drain), so that a recorded step costs a copy or two.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


class Sampler:
    """One backend's reader of fixed sensors, sample by sample or recorded over steps.

    Parameters
    ----------
    sample : callable
        Returns the sensors' current values (without the batch dimension), flattened and concatenated
        into a new float array.

    Notes
    -----
    ``sampler()`` gives one sample (a new array at each call). :meth:`record` keeps the current sample;
    :meth:`drain` returns every sample kept since the last drain, in order, as rows equal to what
    ``sampler()`` returned at each :meth:`record`. This base class records by calling ``sample``; an
    engine's subclass may record its raw state and finish it in :meth:`drain`.
    """

    def __init__(self, sample: Callable[[], np.ndarray]) -> None:
        self._sample = sample
        self._kept: list[np.ndarray] = []

    def __call__(self) -> np.ndarray:
        return self._sample()

    def record(self) -> None:
        """Keep the current sample."""
        self._kept.append(self._sample())

    def drain(self) -> np.ndarray:
        """The samples kept since the last drain, shape (T, size) (T may be 0, then size is 0 too)."""
        kept, self._kept = self._kept, []
        return np.array(kept, dtype=float) if kept else np.zeros((0, 0))


class RawRowSampler(Sampler):
    """A :class:`Sampler` that records contiguous stretches of an engine's state arrays and finishes the
    rows at the drain.

    Parameters
    ----------
    sample : callable
        As for :class:`Sampler` (the one-sample read).
    spans : sequence of (ndarray, int, int)
        Each an engine array (a view that stays valid for the loaded model) and the stretch
        ``[start, stop)`` of it to copy at each record: a raw row is the stretches side by side.
    finish : callable
        ``finish(raw)`` turns raw rows (T, raw size) into the samples (T, size), as ``sample`` would
        have given them.
    capacity : int
        Rows allocated at first; the buffer doubles when full.
    """

    def __init__(self, sample: Callable[[], np.ndarray], spans, finish: Callable[[np.ndarray], np.ndarray],
                 capacity: int = 128) -> None:
        super().__init__(sample)
        self._finish = finish
        self._spans = []
        column = 0
        for array, start, stop in spans:
            self._spans.append((array, int(start), int(stop), column, column + int(stop) - int(start)))
            column += int(stop) - int(start)
        self._raw = np.empty((max(int(capacity), 1), column))
        self._count = 0

    def record(self) -> None:
        if self._count == len(self._raw):
            self._raw = np.concatenate([self._raw, np.empty_like(self._raw)])
        row = self._raw[self._count]
        for array, start, stop, first, last in self._spans:
            row[first:last] = array[start:stop]
        self._count += 1

    def drain(self) -> np.ndarray:
        count, self._count = self._count, 0
        return self._finish(self._raw[:count])
