"""Figures inside the page: a report is one self-contained HTML file (mailed, it keeps them).

A matplotlib figure becomes a PNG ``data:`` URI (base64), put in an ``<img src=...>``; no
file is written beside the page.
"""

from __future__ import annotations

import base64
import html
import io

import matplotlib

matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

__all__ = ["DATA_URI_PREFIX", "image", "png_data_uri"]

DATA_URI_PREFIX = "data:image/png;base64,"
"""How every figure's ``src`` starts."""


def png_data_uri(figure: Figure, dpi: int) -> str:
    """The figure as a PNG ``data:`` URI; the figure is closed."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    plt.close(figure)
    return DATA_URI_PREFIX + base64.b64encode(buffer.getvalue()).decode("ascii")


def image(uri: str, alt: str, caption: str = "") -> str:
    """An ``<img>`` of a data URI, full width, with its caption (HTML) below it."""
    below = f"<figcaption>{caption}</figcaption>" if caption else ""
    return (
        f'<figure><img src="{uri}" alt="{html.escape(alt)}" style="max-width:100%">'
        f"{below}</figure>"
    )
