"""The Starlette app: the page, its settings catalogue, and the websocket that drives the bus."""

from __future__ import annotations

import asyncio
import contextlib
import json
import secrets
import time
from collections import deque
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, PlainTextResponse, RedirectResponse, Response
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect

from .. import __version__
from ..drivers.sync import Bus
from . import commands as c
from . import tune_panel
from .busstats import FrameRate, bus_stats
from .connlimits import quiet_emfile
from .frames import FrameTap
from .security import TOKEN_COOKIE, SecurityPolicy, security_headers
from .worker import BusWorker

STATIC = Path(__file__).parent / "static"
UPLOT = "vendor/uplot/uPlot.esm.js"  # from npm, not committed: scripts/dashboard-assets.sh
MISSING_ASSETS = (
    "the console's plotting library (uPlot, from npm) is not installed next to the page: "
    "run `bash scripts/dashboard-assets.sh` (or `make dashboard`) in the nurimc source tree"
)
FLUSH_SECONDS = 0.02  # samples and frames go out in batches 50 times a second
TICK_SECONDS = 1.0  # a heartbeat to every page: a page that hears nothing for 3 s knows the server is gone
LIVE_QUEUE = 256  # live-data messages waiting for a slow page before the oldest are dropped
REPLY_BACKLOG = 1024  # replies and events waiting for a page before its messages stop being read
MAX_NESTING = 32  # deeper JSON is refused before it is decoded
# Two limits on one message (docs/dashboard.md, "Malformed messages"). Up to MESSAGE_LIMIT the console
# reads it; above, up to TRANSPORT_LIMIT, the websocket layer still assembles it (bounded memory) and the
# console answers an error reply on the open connection; above TRANSPORT_LIMIT the websocket layer
# itself closes the connection with 1009 "message too big", as a last resort against unbounded memory.
MESSAGE_LIMIT = 1 << 20  # 1 MiB
TRANSPORT_LIMIT = 16 << 20  # 16 MiB: uvicorn's ws_max_size, websockets' max_size (whole message, all fragments)
LIVE_EVENTS = {"samples", "frames", "tick"}
# Fairness under a flood (docs/dashboard.md, "Port lost and floods"): every message read gives the
# other connections a turn; a page that does not read its replies stops being read (REPLY_BACKLOG)
# and, after STALLED_SECONDS of that, is disconnected.
#: a page that takes none of its replies for this long is disconnected (1008), not waited for
STALLED_SECONDS = 30.0
POLICY_VIOLATION = 1008


@dataclass
class DashboardConfig:
    bus: Bus
    tap: FrameTap
    policy: SecurityPolicy
    product: str = "mc"
    sim: bool = False
    port: str = ""
    on_ready: Callable[[], None] | None = None
    #: given the bus worker once it exists (the shared bus: docs/service.md)
    on_worker: Callable[[BusWorker], None] | None = None


class GuardMiddleware:
    """Host check and token on every request and websocket, before any route runs."""

    def __init__(self, app: ASGIApp, policy: SecurityPolicy) -> None:
        self.app = app
        self.policy = policy

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        request = Request(scope) if scope["type"] == "http" else WebSocket(scope, receive, send)
        host = request.headers.get("host")
        if scope["type"] == "http":
            send = _with_headers(send, security_headers(host if self.policy.host_allowed(host) else None))
        if not self.policy.host_allowed(host):
            await self._refuse(scope, receive, send, 421, f"Host {host!r} is not this console; use http://127.0.0.1")
            return
        presented = request.query_params.get("token") or request.cookies.get(TOKEN_COOKIE)
        if not self.policy.token_ok(presented):
            await self._refuse(
                scope, receive, send, 401, "this console needs its token: open http://HOST:PORT/?token=YOUR_TOKEN"
            )
            return
        await self.app(scope, receive, send)

    @staticmethod
    async def _refuse(scope: Scope, receive: Receive, send: Send, status: int, text: str) -> None:
        if scope["type"] == "websocket":
            await WebSocket(scope, receive, send).close(code=POLICY_VIOLATION, reason=text)
        else:
            await PlainTextResponse(text, status_code=status)(scope, receive, send)


def _with_headers(send: Send, headers: list[tuple[bytes, bytes]]) -> Send:
    """Every HTTP answer carries the security headers (security.security_headers)."""

    async def sending(message: Any) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message.get("headers", []), *headers]}
        await send(message)

    return sending


class Outbox:
    """What goes out to one page. Replies and events are never dropped: the page's reading is
    paused instead (backpressure) while too many wait. Live data (samples, frames) is dropped,
    oldest first, for a page too slow to take it."""

    def __init__(self) -> None:
        self.must: deque[str] = deque()
        self.live: deque[str] = deque(maxlen=LIVE_QUEUE)
        self.live_dropped = 0
        self._ready = asyncio.Event()

    def put(self, text: str) -> None:
        self.must.append(text)
        self._ready.set()

    def put_first(self, text: str) -> None:
        """Ahead of everything waiting (the emergency stop's receipt)."""
        self.must.appendleft(text)
        self._ready.set()

    def put_live(self, text: str) -> None:
        if len(self.live) == self.live.maxlen:
            self.live_dropped += 1
        self.live.append(text)
        self._ready.set()

    async def get(self) -> str:
        while not self.must and not self.live:
            self._ready.clear()
            await self._ready.wait()
        return self.must.popleft() if self.must else self.live.popleft()

    async def room(self) -> bool:
        """Wait while the page has not taken its earlier replies (it stops being read meanwhile);
        False if it took none for STALLED_SECONDS (the caller drops the connection)."""
        if len(self.must) <= REPLY_BACKLOG:
            return True
        since = time.monotonic()
        while len(self.must) > REPLY_BACKLOG:
            if time.monotonic() - since > STALLED_SECONDS:
                return False
            await asyncio.sleep(0.02)
        return True


class Hub:
    """The connected pages: each has its own outbox so one slow page cannot stall the others."""

    def __init__(self) -> None:
        self.outboxes: set[Outbox] = set()

    def broadcast(self, event: dict[str, Any]) -> None:
        text = json.dumps(event, default=str)
        live = event.get("type") in LIVE_EVENTS
        for box in self.outboxes:
            (box.put_live if live else box.put)(text)


class UnreadableNumber:
    """A JSON number the console does not read: NaN, Infinity, or an integer past Python's 4,300
    digits. It stays in the message as a placeholder (never a number), so the request is still
    answered with its own `req` and the field check names the field that holds it."""

    __slots__ = ("text",)

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text if len(self.text) <= 24 else f"{self.text[:12]}... ({len(self.text)} digits)"


def _read_int(text: str) -> int | UnreadableNumber:
    try:
        return int(text)
    except ValueError:  # over sys.get_int_max_str_digits()
        return UnreadableNumber(text)


def decode(text: str) -> Any:
    """JSON as the page must send it; NaN, Infinity and huge integers become UnreadableNumber
    (refused by the field checks), nesting is bounded (RecursionError otherwise)."""
    return json.loads(text, parse_constant=UnreadableNumber, parse_int=_read_int)


def uvicorn_options() -> dict[str, Any]:
    """The websocket settings `uvicorn.Config` needs for the console's two message limits.

    websockets' sans-I/O implementation ("websockets-sansio", uvicorn >= 0.35) counts a message's
    size across all its fragments (and after decompression), refuses it from the frame header before
    reading the payload, and pauses reading while an assembled message waits for the app: one
    connection holds at most one message of TRANSPORT_LIMIT. Older uvicorn gets the legacy
    implementation with a receive queue of one message, the same bound."""
    from uvicorn.config import WS_PROTOCOLS

    ws = "websockets-sansio" if "websockets-sansio" in WS_PROTOCOLS else "websockets"
    return {"ws": ws, "ws_max_size": TRANSPORT_LIMIT, "ws_max_queue": 1}


def message_size(event: Any) -> int:
    """Bytes of a received message as sent (text counted in UTF-8)."""
    data = event.get("bytes")
    if data is not None:
        return len(data)
    text: str = event.get("text") or ""
    return len(text) if text.isascii() else len(text.encode("utf-8", "surrogatepass"))


def create_app(config: DashboardConfig) -> Starlette:
    hub = Hub()
    state: dict[str, Any] = {}
    boot = secrets.token_hex(8)  # a page that sees another boot knows the server restarted (new clock, no motors)

    def worker() -> BusWorker:
        w: BusWorker = state["worker"]
        return w

    async def flush() -> None:
        next_tick = 0.0
        frame_rate = FrameRate()  # frames/s on the server's clock (dashboard/busstats.py)
        while True:
            await asyncio.sleep(FLUSH_SECONDS)
            if time.monotonic() >= next_tick:
                next_tick = time.monotonic() + TICK_SECONDS
                hub.broadcast({"type": "tick", "stats": bus_stats(worker().bus, frame_rate)})
            samples = worker().take_samples()
            if samples:
                hub.broadcast({"type": "samples", "rows": samples})
            frames = config.tap.take()
            if frames:
                hub.broadcast({"type": "frames", "frames": frames})

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()
        quiet_emfile(loop)  # out of descriptors at accept(): one line a minute (connlimits.py)

        def publish(event: dict[str, Any]) -> None:  # called from the bus thread
            loop.call_soon_threadsafe(hub.broadcast, event)

        w = BusWorker(config.bus, config.product, publish, config.port, config.tap)
        state["worker"] = w
        if config.on_worker is not None:
            config.on_worker(w)
        w.start()
        flusher = asyncio.create_task(flush())
        if config.on_ready:
            config.on_ready()
        try:
            yield
        finally:
            flusher.cancel()
            w.stop()

    async def index(request: Request) -> Response:
        token = request.query_params.get("token")
        if token is not None:  # move the token from the address bar into a cookie
            response: Response = RedirectResponse("/", status_code=303)
            response.set_cookie(TOKEN_COOKIE, token, httponly=True, samesite="strict")
            return response
        if not (STATIC / UPLOT).is_file():
            return PlainTextResponse(MISSING_ASSETS, status_code=503)
        return HTMLResponse((STATIC / "index.html").read_text(encoding="utf-8"))

    async def info(request: Request) -> Response:
        w = worker()
        return JSONResponse(
            {
                "server": "nurimc-dashboard",
                "version": __version__,
                "sim": config.sim,
                "product": config.product,
                "baudrate": w.bus.baudrate,
                "port": w.port,
                "known": {str(k): v for k, v in w.known.items()},
                "motors": w.motor_list(),
                "generation": w.generation,
                "reads": w.reads,
                "port_state": w.port_state(),
                "settings": c.settings_catalogue(),
            }
        )

    async def socket(websocket: WebSocket) -> None:
        if not config.policy.origin_allowed(websocket.headers.get("origin"), websocket.headers.get("host")):
            await websocket.close(code=POLICY_VIOLATION, reason="cross-origin websocket refused")
            return
        await websocket.accept()
        box = Outbox()
        w = worker()
        box.put(json.dumps(hello(w)))
        hub.outboxes.add(box)
        loop = asyncio.get_running_loop()

        async def send_loop() -> None:
            while True:
                await websocket.send_text(await box.get())

        sender = asyncio.create_task(send_loop())
        try:
            await _receive_loop(websocket, config, w, box, loop)
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()
            hub.outboxes.discard(box)
            w.forget(box)

    def hello(w: BusWorker) -> dict[str, Any]:
        return {
            "type": "hello",
            "boot": boot,
            "clock": round(time.monotonic() - w.clock_origin, 4),  # the samples' time axis, now
            "generation": w.generation,
            "motors": w.motor_list(),
            "watching": list(w.watched),
            "sim": config.sim,
            "baudrate": w.bus.baudrate,
            "port": w.port,
            "port_state": w.port_state(),  # up, stop_pending, message while lost (docs/dashboard.md, "Port lost")
        }

    routes = [
        Route("/", index),
        Route("/api/info", info),
        WebSocketRoute("/ws", socket),
        Mount("/", StaticFiles(directory=STATIC), name="static"),  # the page's files, relative to it
    ]
    app = Starlette(routes=routes, lifespan=lifespan)
    app.add_middleware(GuardMiddleware, policy=config.policy)
    return app


def _reply(req: Any, result: Any, error: str | None) -> str:
    message = {"type": "reply", "req": req, "ok": error is None, "result": result, "error": error}
    return json.dumps(message, default=str)


def _request_id(message: Any) -> Any:
    """The page's request number, echoed only if it is a plain number or short text."""
    req = message.get("req") if isinstance(message, dict) else None
    if isinstance(req, bool) or not isinstance(req, int | str) or (isinstance(req, str) and len(req) > 64):
        return None
    return req


def _too_deep(text: str) -> bool:
    depth = deepest = 0
    in_string = escaped = False
    for ch in text:
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
            if deepest > MAX_NESTING:
                return True
        elif ch in "]}":
            depth -= 1
    return False


async def _receive_loop(
    websocket: WebSocket,
    config: DashboardConfig,
    worker: BusWorker,
    box: Outbox,
    loop: asyncio.AbstractEventLoop,
) -> None:
    """Every message gets exactly one reply; a bad one gets an error reply and the connection stays open."""
    while True:
        if not await box.room():
            await websocket.close(code=POLICY_VIOLATION, reason=f"no replies taken for {STALLED_SECONDS:g} s")
            raise WebSocketDisconnect(POLICY_VIOLATION)
        await asyncio.sleep(0)  # a message already buffered would not yield: give the other connections a turn
        event = await websocket.receive()
        if event["type"] == "websocket.disconnect":
            raise WebSocketDisconnect(event.get("code", 1000))
        size = message_size(event)
        if size > MESSAGE_LIMIT:  # read no further; the connection stays open
            box.put(_reply(None, None, f"message of {size} bytes is over the {MESSAGE_LIMIT >> 20} MiB limit"))
            continue
        text = event.get("text")
        if text is None:
            box.put(_reply(None, None, "binary messages are not understood: send JSON text"))
            continue
        req: Any = None
        try:
            if _too_deep(text):
                raise c.CommandError(f"message nested deeper than {MAX_NESTING} levels")
            message = decode(text)
            req = _request_id(message)
            command = c.parse(message)
            generation = c.generation_of(message)
        except json.JSONDecodeError as error:
            box.put(_reply(req, None, f"not JSON: {error}"))
            continue
        except (c.CommandError, ValueError, RecursionError, ArithmeticError, TypeError) as error:
            plain = isinstance(error, c.CommandError | ValueError)
            reason = str(error) if plain else f"refused: {type(error).__name__}"
            box.put(_reply(req, None, reason))
            continue
        except Exception as error:  # never let one message close the page's connection
            box.put(_reply(req, None, f"internal error: {type(error).__name__}: {error}"))
            continue
        if isinstance(command, tune_panel.TuneCancel):  # out of band: the worker is busy with the tune
            box.put(_reply(req, tune_panel.cancel(), None))
            continue
        # what the page may open (security.port_refusal); the port the console already holds (given on
        # its command line) may always be reopened: that is no new reach for the page
        refusal = None
        if isinstance(command, c.OpenBus) and command.port != worker.port:
            refusal = config.policy.port_refusal(command.port)
        if refusal is not None:  # what the page may open (security.port_refusal)
            box.put(_reply(req, None, f"open_bus: {refusal}"))
            continue
        if isinstance(command, c.Frames):  # the raw view: no bus work, just whether frames are queued
            config.tap.enabled = command.on
            recent = list(config.tap.recent) if command.on else []
            box.put(_reply(req, {"recent": recent}, None))
            continue

        def done(result: Any, error: str | None, req: Any = req) -> None:  # from the bus thread
            text = _reply(req, result, error)
            loop.call_soon_threadsafe(box.put, text)

        def received(stop_generation: int, req: Any = req) -> None:  # the page stops waiting for a server that is gone
            box.put_first(json.dumps({"type": "estop_received", "req": req, "generation": stop_generation}))

        worker.submit(command, done, owner=box, generation=generation, received=received)
