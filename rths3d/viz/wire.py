"""A headless viser client: connect to a view and decode what it sends (tests, benchmarks).

viser's wire format (viser 1.x): each websocket frame is ``[u64 msgpack size][u64 zstd size]
[zstd-compressed msgpack][padding to 8 bytes][binary buffers, each 8-byte aligned]``; numpy
arrays travel as binary buffers referenced by ``{"__binary_index": i, "dtype": ...}``. The
client must ask for the subprotocol ``viser-v<version>``.
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import numpy as np

CAMERA = {"type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0],
          "position": [1.0, -1.2, 0.9], "fov": 1.0, "near": 0.01, "far": 100.0,
          "image_height": 720, "image_width": 1280, "look_at": [0.0, 0.0, 0.3],
          "up_direction": [0.0, 0.0, 1.0]}
"""The camera report a headless client sends on connecting (m, rad; like a browser's)."""


def decode_frame(frame: bytes) -> list[dict[str, Any]]:
    """The messages of one frame, binary placeholders replaced by numpy arrays."""
    import msgspec
    import zstandard

    size = int.from_bytes(frame[0:8], "little")
    zsize = int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16:16 + zsize], max_output_size=size)
    payload = msgspec.msgpack.decode(inner)
    lengths = payload.get("binaryBufferLengths") or ()
    offset = 16 + zsize
    buffers = []
    for n in lengths:
        offset += (-offset) % 8
        buffers.append(frame[offset:offset + n])
        offset += n

    def resolve(obj: Any) -> Any:
        if isinstance(obj, dict):
            if "__binary_index" in obj and "dtype" in obj:
                return np.frombuffer(buffers[obj["__binary_index"]], dtype=obj["dtype"])
            return {k: resolve(v) for k, v in obj.items()}
        if isinstance(obj, list):
            return [resolve(v) for v in obj]
        return obj

    return [resolve(m) for m in payload.get("messages", [])]


class HeadlessClient:
    """Connects to a viser server in a background thread and keeps every decoded message.

    ``messages`` grows as frames arrive (list of dicts, each with a ``type``); ``frames``
    counts frames. Like a browser it reports a camera first, which is when viser counts a
    client as connected (``on_client_connect``). Use as a context manager or call
    :meth:`close`.
    """

    def __init__(self, port: int, host: str = "127.0.0.1", *, keep: bool = True):
        import viser

        self.keep = keep
        """Decode and keep every message (False: only count frames, as cheap as possible)."""
        self.url = f"ws://{host}:{port}"
        self.subprotocol = f"viser-v{viser.__version__}"
        self.messages: list[dict[str, Any]] = []
        self.frames = 0
        self.error: BaseException | None = None
        self._lock = threading.Lock()
        self._connected = threading.Event()
        self._loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._run, name="viser-headless", daemon=True)
        self._thread.start()
        if not self._connected.wait(10.0):
            self.close()
            raise ConnectionError(f"could not connect to {self.url}: {self.error!r}")

    def _run(self) -> None:
        self._loop.run_until_complete(self._main())

    async def _main(self) -> None:
        import msgspec
        import websockets

        self._stop = asyncio.Event()
        try:
            async with websockets.connect(self.url, subprotocols=[self.subprotocol],
                                          max_size=None) as ws:
                await ws.send(msgspec.msgpack.encode(CAMERA))
                self._connected.set()
                while not self._stop.is_set():
                    try:
                        frame = await asyncio.wait_for(ws.recv(), 0.1)
                    except TimeoutError:
                        continue
                    if isinstance(frame, bytes):
                        msgs = decode_frame(frame) if self.keep else []
                        with self._lock:
                            self.frames += 1
                            self.messages.extend(msgs)
        except BaseException as exc:  # reported through .error / the constructor
            self.error = exc
            self._connected.set()

    def snapshot(self) -> list[dict[str, Any]]:
        """A copy of the messages received so far."""
        with self._lock:
            return list(self.messages)

    def close(self) -> None:
        """Disconnect and stop the thread."""
        if self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(timeout=5.0)

    def __enter__(self) -> HeadlessClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
