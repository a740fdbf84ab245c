"""Real-time playback of an exported avatar: numpy bone matrices, GL neural rasterization
(skinning + 16-channel uint8 texture lookup), the int8 ONNX renderer and compositing. Torch-free.

Entry point: :class:`morf.playback.player.Player`.
"""
