"""Matplotlib figures without pyplot: headless (Agg), no global figure state."""

__all__ = ["new_figure"]


def new_figure(**kwargs):
    """A :class:`matplotlib.figure.Figure` with constrained layout, on the Agg backend.

    Args:
        **kwargs: passed to ``Figure`` (e.g. ``figsize``).

    Returns:
        matplotlib.figure.Figure; save it with ``fig.savefig(path)``.
    """
    import matplotlib  # deferred: matplotlib is slow to load

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kwargs)
