"""Real-time playback of an exported avatar: numpy bone matrices, GL neural rasterization
(skinning + 16-channel uint8 texture lookup, :mod:`morf.raster.neural_raster`), the int8 ONNX
renderer and compositing. Torch-free.

Entry point: :class:`morf.playback.player.Player`.
"""
