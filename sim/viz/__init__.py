"""Drawing: the GL backend (``gl``), the one renderer (``renderer``), what a frame is made of
(``scene``), a frame's layout and text beside the world picture (``panel``), replay of run logs
into frames (``replay``) and its fixed-view compositing (``compose``), the MP4 writer (``video``)
and the report plots (``plots``).

Importing this package imports neither mujoco nor matplotlib and changes no environment variable.
"""
