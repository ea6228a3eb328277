"""Figure layout shared by every figure of the package (docs/design.md §7)."""

from __future__ import annotations

from matplotlib.figure import Figure


def tight(fig: Figure) -> Figure:
    """``fig.tight_layout()`` once, then no layout engine: ``tight_layout`` leaves a
    placeholder engine behind, and with any engine ``savefig`` draws the whole figure once
    more before rendering it (30 ms a figure here) for the same pixels."""
    fig.tight_layout()
    fig.set_layout_engine(None)
    return fig
