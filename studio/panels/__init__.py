"""The studio's panels: each a ``draw(state, ui)`` function in its own module."""
