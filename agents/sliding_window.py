"""The largest value seen over the last seconds, for the pessimistic memories of the shield and the rule-based
controller (a monotonic deque: O(1) per sample instead of a scan of the whole window)."""

from __future__ import annotations

from collections import deque


class WindowMax:
    """Maximum of the values pushed within ``span_s`` of the latest push (``sign=-1``: the minimum).

    Parameters
    ----------
    span_s : float
        Memory: a value pushed at ``t`` is forgotten once a push comes at a time later than ``t + span_s``.
    sign : float
        ``1.0`` for the maximum, ``-1.0`` for the minimum.
    """

    def __init__(self, span_s: float, sign: float = 1.0) -> None:
        self.span_s = span_s
        self.sign = sign
        self._q: deque[tuple[float, float]] = deque()

    def push(self, t_s: float, x: float) -> None:
        """Add ``x`` at time ``t_s`` (non-decreasing) and forget what is older than ``t_s - span_s``."""
        q, y = self._q, self.sign * x
        while q and q[-1][1] <= y:  # never again the extreme while y is in the window
            q.pop()
        q.append((t_s, y))
        cutoff = t_s - self.span_s
        while q[0][0] < cutoff:
            q.popleft()

    def value_within(self, t_s: float, span_s: float) -> float | None:
        """The extreme of the values pushed at ``t_s - span_s`` or later (``span_s <= self.span_s``), or None.

        The deque holds the window's extremes in time order, each larger (for ``sign=1``) than every later one, so
        the extreme of any more recent part of the window is its first entry that falls inside it."""
        cutoff = t_s - span_s
        for t, y in self._q:
            if not t < cutoff:
                return self.sign * y
        return None

    @property
    def value(self) -> float | None:
        """The window's extreme, or None before the first push."""
        return self.sign * self._q[0][1] if self._q else None


__all__ = ["WindowMax"]
