"""Export: a trained avatar as a portable folder (uint8 neural texture, shaped render mesh,
skeleton, fp32 + int8 ONNX renderers, manifest). Reading a folder needs no torch; writing one does.

Modules are imported on use so that ``morf.export.avatar_folder`` stays torch-free.
"""
