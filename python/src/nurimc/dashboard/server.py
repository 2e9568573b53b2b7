"""The Starlette app: the page, its settings catalogue, and the websocket that drives the bus."""

from __future__ import annotations

import asyncio
import contextlib
import json
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
from ..client.sync import Bus
from . import commands as c
from .frames import FrameTap
from .security import TOKEN_COOKIE, SecurityPolicy
from .worker import BusWorker

STATIC = Path(__file__).parent / "static"
UPLOT = "vendor/uplot/uPlot.esm.js"  # from npm, not committed: scripts/dashboard-assets.sh
MISSING_ASSETS = (
    "the console's plotting library (uPlot, from npm) is not installed next to the page: "
    "run `bash scripts/dashboard-assets.sh` (or `make dashboard`) in the nurimc source tree"
)
FLUSH_SECONDS = 0.02  # samples and frames go out in batches 50 times a second
CLIENT_QUEUE = 256  # messages waiting for a slow page before its live data is dropped
POLICY_VIOLATION = 1008


@dataclass
class DashboardConfig:
    bus: Bus
    tap: FrameTap
    policy: SecurityPolicy
    product: str = "mc"
    sim: bool = False
    on_ready: Callable[[], None] | None = None


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


class Hub:
    """The connected pages: each gets its own queue so one slow page cannot stall the others."""

    def __init__(self) -> None:
        self.queues: set[asyncio.Queue[str]] = set()

    def broadcast(self, event: dict[str, Any]) -> None:
        text = json.dumps(event)
        for queue in self.queues:
            with contextlib.suppress(asyncio.QueueFull):  # a stalled page misses live data, not replies
                queue.put_nowait(text)


def create_app(config: DashboardConfig) -> Starlette:
    hub = Hub()
    state: dict[str, Any] = {}

    def worker() -> BusWorker:
        w: BusWorker = state["worker"]
        return w

    async def flush() -> None:
        while True:
            await asyncio.sleep(FLUSH_SECONDS)
            samples = worker().take_samples()
            if samples:
                hub.broadcast({"type": "samples", "rows": samples})
            frames = config.tap.take()
            if frames:
                hub.broadcast({"type": "frames", "frames": frames})

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()

        def publish(event: dict[str, Any]) -> None:  # called from the bus thread
            loop.call_soon_threadsafe(hub.broadcast, event)

        w = BusWorker(config.bus, config.product, publish)
        state["worker"] = w
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
                "baudrate": config.bus.baudrate,
                "known": {str(k): v for k, v in w.known.items()},
                "reads": w.reads,
                "settings": c.settings_catalogue(),
            }
        )

    async def socket(websocket: WebSocket) -> None:
        if not config.policy.origin_allowed(websocket.headers.get("origin"), websocket.headers.get("host")):
            await websocket.close(code=POLICY_VIOLATION, reason="cross-origin websocket refused")
            return
        await websocket.accept()
        queue: asyncio.Queue[str] = asyncio.Queue(CLIENT_QUEUE)
        hub.queues.add(queue)
        loop = asyncio.get_running_loop()

        def reply_to(req: Any) -> Callable[[Any, str | None], None]:
            def done(result: Any, error: str | None) -> None:
                message = {"type": "reply", "req": req, "ok": error is None, "result": result, "error": error}
                loop.call_soon_threadsafe(queue.put_nowait, json.dumps(message, default=str))

            return done

        async def send_loop() -> None:
            while True:
                await websocket.send_text(await queue.get())

        sender = asyncio.create_task(send_loop())
        try:
            await _receive_loop(websocket, config, worker, queue, reply_to)
        except WebSocketDisconnect:
            pass
        finally:
            sender.cancel()
            hub.queues.discard(queue)

    routes = [
        Route("/", index),
        Route("/api/info", info),
        WebSocketRoute("/ws", socket),
        Mount("/", StaticFiles(directory=STATIC), name="static"),  # the page's files, relative to it
    ]
    app = Starlette(routes=routes, lifespan=lifespan)
    app.add_middleware(GuardMiddleware, policy=config.policy)
    return app


async def _receive_loop(
    websocket: WebSocket,
    config: DashboardConfig,
    worker: Callable[[], BusWorker],
    queue: asyncio.Queue[str],
    reply_to: Callable[[Any], Callable[[Any, str | None], None]],
) -> None:
    while True:
        text = await websocket.receive_text()
        req: Any = None
        try:
            message = json.loads(text)
            req = message.get("req") if isinstance(message, dict) else None
            command = c.parse(message)
        except (json.JSONDecodeError, c.CommandError) as error:
            reason = f"not JSON: {error}" if isinstance(error, json.JSONDecodeError) else str(error)
            await websocket.send_text(json.dumps({"type": "reply", "req": req, "ok": False, "error": reason}))
            continue
        if isinstance(command, c.Frames):  # the raw view: no bus work, just whether frames are queued
            config.tap.enabled = command.on
            recent = list(config.tap.recent) if command.on else []
            await websocket.send_text(
                json.dumps({"type": "reply", "req": req, "ok": True, "result": {"recent": recent}})
            )
            continue
        worker().submit(command, reply_to(req))
