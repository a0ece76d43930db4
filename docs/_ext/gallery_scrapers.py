"""A sphinx-gallery image scraper for figures built without pyplot.

``nh_operators.evaluation.plots`` returns :class:`matplotlib.figure.Figure` objects that pyplot
does not know about (no global figure state), so sphinx-gallery's own matplotlib
scraper cannot see them. This one looks for such figures among the example's
variables after each code block and saves every one it has not shown yet. It must run
before sphinx-gallery's matplotlib scraper, which closes the pyplot figures it saves
(a closed pyplot figure looks like a pyplot-free one).
"""

import weakref

_SHOWN = weakref.WeakSet()


def figure_scraper(block, block_vars, gallery_conf):
    """Save the new pyplot-free figures of a code block and return their rST."""
    from matplotlib.figure import Figure
    from sphinx_gallery.scrapers import figure_rst

    figures = []
    for value in list(block_vars["example_globals"].values()):
        if not isinstance(value, Figure) or value in _SHOWN:
            continue
        _SHOWN.add(value)
        if value.canvas.manager is None:  # pyplot figures: sphinx-gallery's own scraper
            figures.append(value)
    paths = []
    for fig, path in zip(figures, block_vars["image_path_iterator"]):
        fig.savefig(path, dpi=90)
        paths.append(path)
    return figure_rst(paths, gallery_conf["src_dir"])
