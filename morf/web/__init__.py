"""The avatar in a web page: a static folder (page, player scripts, the avatar's uint8 neural
texture, mesh, skinning, int8 ONNX renderer, motions) that plays the neural avatar live in a
browser (WebGL2 + onnxruntime-web), a local server with the cross-origin isolation headers that
WASM threads need, and the headless-Chromium driver that the tests and ``morf bench web`` use.
See docs/web.md."""
