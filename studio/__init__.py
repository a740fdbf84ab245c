"""MoRF Studio: the desktop app (GLFW + moderngl + imgui-bundle) built on the ``morf`` library.

Start it with ``morf-studio [PROJECT]``. The library never imports this package.
"""
